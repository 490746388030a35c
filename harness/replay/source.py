"""What replay reads from a recording: the model, the version check, the recorded states and
the applied inputs, as numpy arrays.

Which model a recording is replayed with, in order of preference:

1. ``model.mjb``: the exact binary model (``LoadedRobot.mjb``), bit for bit what was simulated;
2. the source attachments (``source/model/...``, ``source/scene/...``) rebuilt with
   :func:`harness.models.load_robot` and the recorded control modes, accepted only when the
   rebuilt MJCF's SHA-256 equals the recorded ``model_sha256``; a recording of several robots
   (metadata ``robots``, see :mod:`harness.recording.describe`) is rebuilt with
   :func:`harness.models.load_world`: the same robots, namespaces, poses, control modes,
   initial positions, objects, scene and timestep (:func:`rebuild_run`);
3. ``model.mjcf.xml``, the compiled MJCF: MuJoCo writes it with 6 significant digits, so it is
   exact only for models that were written at full precision (hand-written MJCF); its SHA-256
   must equal ``model_sha256``.

Every rebuild goes through :mod:`harness.replay.gate`: xacro sources are never expanded, every
file a rebuilt model names must be one of the recording's attachments, ``model.mjb`` is first
loaded in a resource-limited child process.

Recorded states are decoded in bulk, straight from the decompressed chunks
(:meth:`harness.recording.Recording.physics_state_arrays`).
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.errors import HarnessError, ModelError
from harness.models import (
    CONTROL_MODES,
    DECOMPOSITION_FOLDER,
    DEMO_URDF,
    SCENES,
    ControlMode,
    LoadedRobot,
    LoadedWorld,
    ModelLimitError,
    OutsideReferenceError,
    Pose,
    RobotModel,
    RobotSpec,
    WorldObject,
    XacroError,
    check_mesh_collision,
    load_robot,
    load_world,
)
from harness.recording import (
    ATTACHMENT_MODEL,
    ATTACHMENT_MODEL_BINARY,
    ATTACHMENT_SOURCE_PREFIX,
    ATTACHMENT_SOURCE_REFS,
    PROJECT_REFERENCE_REFUSAL,
    TOPIC_STATE,
    Recording,
    RecordingDamagedError,
    RecordingFormatError,
)
from harness.replay.errors import (
    ModelAttachmentError,
    RecordedDataError,
    UnsafeRecordingError,
    VersionMismatchError,
)
from harness.replay.gate import (
    check_model_source,
    model_from_mjb,
    model_from_mjcf_text,
    rebuild_folder,
    recorded_sources,
    source_name,
    warn_left_out,
)
from harness.sim import AppliedInput

__all__ = [
    "RecordedStates",
    "check_chunks",
    "check_states_fit",
    "check_version",
    "control_modes",
    "open_recording",
    "read_inputs",
    "read_states",
    "rebuild_robot",
    "rebuild_run",
    "rebuild_world",
    "resolve_model",
    "run_description",
    "state_blocks",
]

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
_MODEL_SUFFIXES = (".urdf", ".xacro", ".sdf", ".world", ".xml", ".mjcf")


def open_recording(
    path: str | Path, *, allow_damaged: bool = False, defer_chunk_checks: bool = False
) -> Recording:
    """Open ``path``; a truncated or corrupted file is refused (naming the byte offset)
    unless ``allow_damaged``, which replays what precedes the damage.
    ``defer_chunk_checks``: see :class:`~harness.recording.Recording` (damage inside a chunk
    of a complete file is then refused when the chunk is read)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = Recording(path, defer_chunk_checks=defer_chunk_checks)
    if rec.problems and not allow_damaged:
        text = rec.problem_text()
        rec.close()
        raise RecordedDataError(f"{path}: the recording is damaged ({text}){_DAMAGED_HINT}")
    if ATTACHMENT_SOURCE_REFS in rec.attachment_names:
        rec.close()
        raise UnsafeRecordingError(f"{path}: {PROJECT_REFERENCE_REFUSAL}")
    return rec


# Not every command that opens a recording has --allow-damaged (play, diff): say which does.
_DAMAGED_HINT = (
    "; harness replay --allow-damaged (allow_damaged=True) replays what is intact, "
    "harness repair IN OUT rewrites it as a sound recording"
)


def _damaged(rec: Recording, exc: RecordingDamagedError) -> RecordedDataError:
    return RecordedDataError(f"{rec.path}: the recording is damaged ({exc}){_DAMAGED_HINT}")


def check_chunks(rec: Recording) -> None:
    """Check the chunks the replay did not read (deferred checks): every chunk's CRC is
    checked before a replay is reported."""
    try:
        rec.check_chunks()
    except RecordingDamagedError as exc:
        raise _damaged(rec, exc) from None


def check_version(rec: Recording, *, tolerant: bool) -> str:
    """The recorded MuJoCo version; a different one than this process's is refused unless
    the comparison is ``tolerant`` (a non-zero atol or rtol)."""
    recorded = rec.metadata.get("mujoco_version", "")
    running = mujoco.__version__
    if not recorded:
        raise RecordedDataError(f"{rec.path}: metadata has no 'mujoco_version'")
    if recorded != running and not tolerant:
        raise VersionMismatchError(
            f"{rec.path}: recorded with MuJoCo {recorded}, this is MuJoCo {running}: bit-exact "
            "replay is defined only on the same version (results differ from the first step); "
            "compare with tolerances instead, e.g. --atol 1e-6 --rtol 1e-6"
        )
    return recorded


def control_modes(rec: Recording) -> dict[str, ControlMode]:
    """The recorded control mode of every controllable joint."""
    raw = rec.metadata.get("control_modes", "")
    try:
        modes = json.loads(raw)
    except json.JSONDecodeError:
        modes = None
    if not isinstance(modes, dict) or not all(
        isinstance(k, str) and v in CONTROL_MODES for k, v in modes.items()
    ):
        raise RecordedDataError(
            f"{rec.path}: metadata 'control_modes' is {raw[:80]!r}, not a JSON object of "
            f"joint -> one of {', '.join(CONTROL_MODES)}"
        )
    return {str(k): v for k, v in modes.items()}


def _scene(sources: Mapping[str, bytes], root: Path) -> str | Path | None:
    scenes = [n for n in sources if n.startswith("scene/")]
    if not scenes:
        return None
    # the scene file itself, not a model an SDF world includes (scene/include/...) nor a
    # file its visuals read beside it (scene/wall.png)
    top = [n for n in scenes if "/" not in n[6:]]
    scenes = [n for n in top if n.lower().endswith((".world", ".sdf", ".xml"))] or top or scenes
    for named, scene_path in SCENES.items():
        if sources[scenes[0]] == scene_path.read_bytes():
            return named
    return root / scenes[0]


def _model_source(sources: Mapping[str, bytes], name: str, root: Path) -> str | Path:
    return "demo" if sources[name] == DEMO_URDF.read_bytes() else root / name


def _packages(sources: Mapping[str, bytes], root: Path, prefix: str = "") -> dict[str, Path]:
    """The package folders of the attached meshes of a xacro robot (``package/[<namespace>/]
    <pkg>/...``): what its expanded URDF's ``package://`` references resolve to on replay."""
    start = f"package/{prefix}"
    names = {n[len(start) :].split("/", 1)[0] for n in sources if n.startswith(start)}
    return {name: root / "package" / prefix / name for name in sorted(names) if name}


def _json_metadata(rec: Recording, key: str) -> list[dict[str, Any]]:
    raw = rec.metadata.get(key, "[]")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = None
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise RecordedDataError(
            f"{rec.path}: metadata {key!r} is {raw[:80]!r}, not a JSON list of objects"
        )
    return value


def _json_value(rec: Recording, key: str) -> Any:
    """Metadata ``key`` as JSON (None when absent or not JSON: the checks name it)."""
    raw = rec.metadata.get(key)
    if raw is None:
        return None
    try:
        return json.loads(raw)
    except json.JSONDecodeError:
        return raw


def _pose(values: Any, where: str) -> Pose | None:
    if values is None:
        return None
    if not isinstance(values, list) or len(values) != 7:
        raise RecordedDataError(f"{where}: pose {values!r} is not [x, y, z, qw, qx, qy, qz]")
    x, y, z, qw, qx, qy, qz = (float(v) for v in values)
    return Pose((x, y, z), (qw, qx, qy, qz))


def _robot_spec(
    entry: Mapping[str, Any],
    where: str,
    sources: Mapping[str, bytes],
    root: Path,
    control: ControlMode | Mapping[str, ControlMode] | None,
) -> RobotSpec:
    namespace = str(entry["namespace"])
    prefix = f"{namespace}/" if namespace else ""
    source = entry["source"]
    if not isinstance(source, str) or source_name(source) is None:
        raise ModelAttachmentError(f"{where}: its source {source!r} is not an attachment name")
    if source not in sources:
        raise ModelAttachmentError(
            f"{where}: its source {source!r} is not attached (sources: {', '.join(sources)})"
        )
    recorded: dict[str, ControlMode] = dict(entry["control"])
    modes: ControlMode | dict[str, ControlMode] = recorded
    if isinstance(control, str):
        modes = control
    elif control is not None:
        modes = {j: control.get(prefix + j, m) for j, m in recorded.items()}
    srdf = entry.get("srdf")
    if srdf is not None and (not isinstance(srdf, str) or srdf not in sources):
        raise ModelAttachmentError(f"{where}: its srdf {srdf!r} is not a source attachment")
    return RobotSpec(
        _model_source(sources, source, root),
        namespace=namespace,
        pose=_pose(entry.get("pose"), where),
        control=modes,
        gains=entry.get("gains"),
        packages=_packages(sources, root, prefix) or None,
        srdf=None if srdf is None else root / srdf,
        visuals=bool(entry.get("visuals", False)),
        repair_inertia=bool(entry.get("repair_inertia", False)),
        strict=bool(entry.get("strict", False)),
        initial_positions=dict(entry.get("initial_positions") or {}),
        **_collision_and_base(entry.get("self_collision"), entry.get("base"), srdf is not None),
    )


def _collision_and_base(report: Any, base: Any, srdf: bool) -> dict[str, Any]:
    """The recorded self-collision policy and base kind (issue 14) as load options; none
    for recordings made before they were recorded (``"srdf"`` only when the SRDF is)."""
    options: dict[str, Any] = {}
    policies = ("auto", "off", "on", "srdf") if srdf else ("auto", "off", "on")
    # only a policy that was passed: one the file chose (its self_collide, per link too),
    # the SRDF or the default comes back from the same sources by itself
    if (
        isinstance(report, dict)
        and report.get("policy") in policies
        and report.get("origin", "argument") == "argument"
    ):
        options["self_collision"] = report["policy"]
    if base in ("fixed", "floating"):
        options["base"] = base
    return options


def _mesh_collision(rec: Recording, root: Path) -> dict[str, Any]:
    """The recorded ``mesh_collision`` (``hull`` for a recording older than decomposition)
    and the recorded pieces as the cache (``source/decomposition/``): a rebuild never
    decomposes again."""
    mode = rec.metadata.get("mesh_collision", "hull")
    options: dict[str, Any] = {
        "mesh_collision": check_mesh_collision(mode, f"{rec.path}: metadata 'mesh_collision'")
    }
    if (root / DECOMPOSITION_FOLDER).is_dir():
        options["cache_dir"] = root / DECOMPOSITION_FOLDER
    return options


def rebuild_world(
    rec: Recording, control: ControlMode | Mapping[str, ControlMode] | None = None
) -> LoadedWorld:
    """The world of a recording of several robots (metadata ``robots``) rebuilt from its
    source attachments with :func:`harness.models.load_world`. ``control``: one mode for
    every joint, or MuJoCo (prefixed) joint name -> mode (joints not named keep their
    recorded mode); default: the recorded modes."""
    gated = recorded_sources(rec)
    sources = gated.files
    entries = _json_metadata(rec, "robots")
    if not entries:
        raise ModelAttachmentError(f"{rec.path}: metadata 'robots' lists no robot")
    for entry in entries:
        if isinstance(entry.get("source"), str):
            check_model_source(rec, gated, entry["source"])
    warn_left_out(rec, gated)
    with rebuild_folder(rec, sources) as root:
        try:
            specs = [
                _robot_spec(entry, f"{rec.path}: metadata robots[{i}]", sources, root, control)
                for i, entry in enumerate(entries)
            ]
            objects = [
                WorldObject(
                    name=str(obj["name"]),
                    shape=obj["shape"],
                    size=tuple(float(v) for v in obj["size"]),
                    pose=obj.get("pose"),
                    mass=obj.get("mass"),
                    rgba=None if obj.get("rgba") is None else tuple(obj["rgba"]),
                    friction=None if obj.get("friction") is None else tuple(obj["friction"]),
                )
                for obj in _json_metadata(rec, "objects")
            ]
        except (KeyError, TypeError, ValueError) as exc:
            raise RecordedDataError(
                f"{rec.path}: metadata 'robots'/'objects' is malformed: {exc!r}"
            ) from None
        timestep = rec.metadata.get("timestep")
        try:
            return load_world(
                specs,
                scene=_scene(sources, root),
                objects=objects,
                timestep=float(timestep) if timestep else None,
                **_mesh_collision(rec, root),
            )
        except (OutsideReferenceError, XacroError):
            raise  # refused by the gate (harness.replay.gate.rebuild_folder)
        except HarnessError as exc:
            raise ModelAttachmentError(
                f"{rec.path}: cannot rebuild the world from its source attachments: {exc}"
            ) from None


def rebuild_run(
    rec: Recording, control: ControlMode | Mapping[str, ControlMode] | None = None
) -> LoadedRobot | LoadedWorld:
    """What the recorded run simulated, rebuilt from its sources: :func:`rebuild_world` for a
    recording of a world (metadata ``robots``), else :func:`rebuild_robot`."""
    if "robots" in rec.metadata:
        return rebuild_world(rec, control)
    return rebuild_robot(rec, control)


def run_description(loaded: LoadedRobot | LoadedWorld) -> RobotModel:
    """The description of a rebuilt run: the robot's, or every robot's by MuJoCo name."""
    if isinstance(loaded, LoadedWorld):
        return loaded.combined_description()
    return loaded.description


def rebuild_robot(
    rec: Recording, control: ControlMode | Mapping[str, ControlMode] | None = None
) -> LoadedRobot:
    """The robot rebuilt from the source attachments with ``control`` (default: the recorded
    control modes). The bundled demo robot and named scenes are recognised by content and
    loaded from the package (so they get the demo's ``home`` keyframe, as when recorded).
    A recording of several robots needs :func:`rebuild_world` (or :func:`rebuild_run`)."""
    if "robots" in rec.metadata:
        raise ModelAttachmentError(
            f"{rec.path}: a recording of a world of several robots: rebuild it with "
            "rebuild_world() or rebuild_run()"
        )
    gated = recorded_sources(rec)
    sources = gated.files

    def model_files(names: Iterable[str]) -> list[str]:
        # the model file itself (meshes it references may be attached under model/ too)
        return [
            n
            for n in names
            if n.startswith("model/") and "/" not in n[6:] and n.lower().endswith(_MODEL_SUFFIXES)
        ]

    models = model_files(sources)
    if not models:  # every model source was xacro: refused, naming it
        for name in model_files(
            n.removeprefix(ATTACHMENT_SOURCE_PREFIX) for n in rec.attachment_names
        ):
            check_model_source(rec, gated, name)
    warn_left_out(rec, gated)
    if len(models) != 1:
        raise ModelAttachmentError(
            f"{rec.path}: expected one 'source/model/...' attachment to rebuild the robot, "
            f"found {len(models)} (attachments: {', '.join(rec.attachment_names)})"
        )
    modes = control_modes(rec) if control is None else control
    with rebuild_folder(rec, sources) as root:
        source = _model_source(sources, models[0], root)
        try:
            return load_robot(
                source,
                control=modes,
                pose=_pose(_json_value(rec, "pose"), f"{rec.path}: metadata 'pose'"),
                scene=_scene(sources, root),
                packages=_packages(sources, root) or None,
                **_mesh_collision(rec, root),
                visuals=rec.metadata.get("visuals") == "true",
                **_collision_and_base(
                    json.loads(rec.metadata.get("self_collision", "null")),
                    rec.metadata.get("base"),
                    srdf=False,
                ),
            )
        except (OutsideReferenceError, XacroError):
            raise  # refused by the gate (harness.replay.gate.rebuild_folder)
        except HarnessError as exc:
            raise ModelAttachmentError(
                f"{rec.path}: cannot rebuild the robot from its source attachments: {exc}"
            ) from None


def resolve_model(rec: Recording) -> tuple[mujoco.MjModel, str]:
    """The model to replay ``rec`` with and where it came from (see the module docstring)."""
    names = set(rec.attachment_names)
    expected_sha = rec.metadata.get("model_sha256", "")
    problems: list[str] = []
    if ATTACHMENT_MODEL_BINARY in names:
        try:
            return model_from_mjb(rec.attachment(ATTACHMENT_MODEL_BINARY)), ATTACHMENT_MODEL_BINARY
        except ModelLimitError as exc:
            raise ModelAttachmentError(f"{rec.path}: {exc}") from None
        except (ValueError, OSError, RecordingDamagedError) as exc:
            problems.append(f"{ATTACHMENT_MODEL_BINARY}: {' '.join(str(exc).split())}")
    # A fallback says so: the replay is then only as exact as the model it was given.
    notice = f" (fell back: {'; '.join(problems)})" if problems else ""
    if any(n.startswith(ATTACHMENT_SOURCE_PREFIX + "model/") for n in names):
        try:
            robot = rebuild_run(rec)
        except UnsafeRecordingError:
            raise  # refused, not a reason to try the next attachment
        except HarnessError as exc:
            problems.append(str(exc))
        else:
            if robot.sha256 == expected_sha:
                return robot.model, "source attachments (rebuilt; MJCF SHA-256 matches)" + notice
            problems.append("source attachments rebuild to a model whose MJCF SHA-256 differs")
    notice = f" (fell back: {'; '.join(problems)})" if problems else ""
    if ATTACHMENT_MODEL in names:
        try:
            text = rec.attachment(ATTACHMENT_MODEL)
        except RecordingDamagedError as exc:
            raise ModelAttachmentError(
                f"{rec.path}: no usable model attachment: {exc}"
                + (f" ({'; '.join(problems)})" if problems else "")
            ) from None
        sha = hashlib.sha256(text).hexdigest()
        if expected_sha and sha != expected_sha:
            raise ModelAttachmentError(
                f"{rec.path}: attachment {ATTACHMENT_MODEL!r} has SHA-256 {sha[:12]}..., the "
                f"metadata's model_sha256 is {expected_sha[:12]}...: the attachment is not the "
                "model this run was recorded with"
                + (f" ({'; '.join(problems)})" if problems else "")
            )
        try:
            model = model_from_mjcf_text(rec, text)
        except ModelError as exc:
            raise ModelAttachmentError(f"{rec.path}: attachment {exc}") from None
        except (ValueError, UnicodeDecodeError) as exc:
            raise ModelAttachmentError(
                f"{rec.path}: attachment {ATTACHMENT_MODEL!r} does not compile: "
                f"{' '.join(str(exc).split())}"
            ) from None
        return model, f"{ATTACHMENT_MODEL} (MJCF text, 6 significant digits){notice}"
    raise ModelAttachmentError(
        f"{rec.path}: no usable model attachment ({ATTACHMENT_MODEL_BINARY}, source/model/..., "
        f"{ATTACHMENT_MODEL}); has: {', '.join(sorted(names)) or 'none'}"
        + (f" ({'; '.join(problems)})" if problems else "")
    )


class RecordedStates(NamedTuple):
    """Every recorded ``PhysicsState``: ``steps`` (N,), ``state`` (N, nstate), ``qpos``
    (N, nq), ``qvel`` (N, nv), the ``state_spec`` they were captured with."""

    steps: I64
    sim_time_ns: I64
    state: F64
    qpos: F64
    qvel: F64
    state_spec: int


def state_blocks(
    rec: Recording,
    model: mujoco.MjModel,
    *,
    rows: int = 4096,
    start_step: int | None = None,
    stop_step: int | None = None,
) -> Iterator[RecordedStates]:
    """The recorded physics states in consecutive blocks of about ``rows`` (whole chunks;
    :meth:`~harness.recording.Recording.physics_state_blocks`), each checked: sizes
    fit ``model``, one state spec throughout, steps increasing, ``sim_time_ns == step *
    timestep_ns``. Raises :class:`~harness.replay.errors.RecordedDataError` at the first
    block that fails, and when there are no states at all."""
    spec: int | None = None
    previous = -1
    dt_ns = rec.timestep_ns
    try:
        for arrays in rec.physics_state_blocks(start_step, stop_step, rows=rows):
            block = RecordedStates(
                arrays.steps, arrays.sim_time_ns, arrays.state, arrays.qpos, arrays.qvel,
                arrays.state_spec,
            )  # fmt: skip
            steps = block.steps
            if spec is None:
                spec = block.state_spec
            elif block.state_spec != spec:
                raise RecordedDataError(
                    f"{rec.path}: physics state at step {int(steps[0])} has state_spec "
                    f"{block.state_spec}, the first has {spec}"
                )
            check_states_fit(rec, model, block)
            order = np.diff(steps, prepend=previous)
            if np.any(order <= 0):
                i = int(np.flatnonzero(order <= 0)[0])
                after = int(steps[i - 1]) if i else previous
                raise RecordedDataError(
                    f"{rec.path}: physics state at step {int(steps[i])} follows step {after}"
                )
            wrong_time = np.flatnonzero(block.sim_time_ns != steps * dt_ns)
            if wrong_time.size:
                i = int(wrong_time[0])
                raise RecordedDataError(
                    f"{rec.path}: physics state at step {int(steps[i])} has sim_time_ns "
                    f"{int(block.sim_time_ns[i])}, not step * dt_ns = {int(steps[i]) * dt_ns}"
                )
            previous = int(steps[-1])
            yield block
    except RecordingDamagedError as exc:
        raise _damaged(rec, exc) from None
    except RecordingFormatError as exc:
        raise RecordedDataError(str(exc)) from None
    if spec is None:
        raise RecordedDataError(f"{rec.path}: no physics states on {TOPIC_STATE}")


def read_states(
    rec: Recording, start_step: int | None = None, stop_step: int | None = None
) -> RecordedStates:
    """The recorded physics states in ``[start_step, stop_step)`` as arrays (decoded in bulk
    by :meth:`~harness.recording.Recording.physics_state_arrays`)."""
    try:
        arrays = rec.physics_state_arrays(start_step, stop_step)
    except RecordingFormatError as exc:
        raise RecordedDataError(str(exc)) from None
    if arrays.steps.size == 0:
        raise RecordedDataError(f"{rec.path}: no physics states on {TOPIC_STATE}")
    return RecordedStates(
        arrays.steps, arrays.sim_time_ns, arrays.state, arrays.qpos, arrays.qvel, arrays.state_spec
    )


def check_states_fit(rec: Recording, model: mujoco.MjModel, states: RecordedStates) -> None:
    """Refuse states whose sizes are not ``model``'s (a model attachment of another run)."""
    size = int(mujoco.mj_stateSize(model, states.state_spec))
    if states.state.shape[1] != size:
        raise RecordedDataError(
            f"{rec.path}: recorded states have {states.state.shape[1]} values, the model's "
            f"state (spec {states.state_spec}) has {size}: the model attachment does not "
            "belong to this recording"
        )
    if states.qpos.shape[1] != model.nq or states.qvel.shape[1] != model.nv:
        raise RecordedDataError(
            f"{rec.path}: recorded qpos/qvel have {states.qpos.shape[1]}/"
            f"{states.qvel.shape[1]} values, the model nq={model.nq} nv={model.nv}: the model "
            "attachment does not belong to this recording"
        )


def read_inputs(
    rec: Recording,
    model: mujoco.MjModel,
    start_step: int | None = None,
    stop_step: int | None = None,
    *,
    after: int = -1,
) -> list[AppliedInput]:
    """The applied inputs in ``[start_step, stop_step)`` in step order, checked against
    ``model``'s sizes; ``after``: the step of the input before them (they must follow it)."""
    out: list[AppliedInput] = []
    previous = after
    try:
        recorded = list(rec.applied_inputs(start_step, stop_step))
    except RecordingDamagedError as exc:
        raise _damaged(rec, exc) from None
    for r in recorded:
        where = f"{rec.path}: applied input at step {r.step}"
        if r.step <= previous:
            raise RecordedDataError(f"{where} follows step {previous}: inputs out of order")
        previous = r.step
        inp = AppliedInput(
            r.step,
            r.sim_time_ns,
            np.asarray(r.ctrl, dtype=np.float64),
            tuple(r.kinematic_joints),
            np.asarray(r.qpos_index, dtype=np.uint32),
            np.asarray(r.qpos_value, dtype=np.float64),
            np.asarray(r.qvel_index, dtype=np.uint32),
            np.asarray(r.qvel_value, dtype=np.float64),
            np.asarray(r.mocap_pos, dtype=np.float64),
            np.asarray(r.mocap_quat, dtype=np.float64),
            np.asarray(r.qfrc_applied, dtype=np.float64),
            np.asarray(r.xfrc_applied, dtype=np.float64),
        )
        checks = (
            (
                inp.ctrl.size == model.nu,
                f"ctrl has {inp.ctrl.size} values, the model nu={model.nu}",
            ),
            (
                inp.qpos_index.size == inp.qpos_value.size
                and inp.qvel_index.size == inp.qvel_value.size,
                "index and value arrays differ in length",
            ),
            (
                bool(np.all(inp.qpos_index < model.nq)) and bool(np.all(inp.qvel_index < model.nv)),
                "a qpos/qvel index is outside the model",
            ),
            (
                inp.mocap_pos.size in (0, 3 * model.nmocap)
                and inp.mocap_quat.size in (0, 4 * model.nmocap),
                "mocap arrays do not match the model's mocap bodies",
            ),
            (inp.qfrc_applied.size in (0, model.nv), f"qfrc_applied is not empty or nv={model.nv}"),
            (
                inp.xfrc_applied.size in (0, 6 * model.nbody),
                f"xfrc_applied is not empty or 6*nbody={6 * model.nbody}",
            ),
        )
        for ok, message in checks:
            if not ok:
                raise RecordedDataError(f"{where}: {message}")
        out.append(inp)
    return out
