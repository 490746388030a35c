"""``load_robot``: a robot description (URDF, SDF, MJCF or the bundled demo) into MuJoCo.

URDF goes through MuJoCo's own URDF importer (mesh URIs resolved and converted first, a
``<mujoco><compiler fusestatic="false" .../>`` element so every link stays a named body), then
one actuator per controllable joint, SRDF collision exclusions, the scene, compile.
"""

from __future__ import annotations

import hashlib
import importlib
import re
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.description import CONTROL_MODES, ControlMode, RobotModel
from harness.models.errors import (
    CompileError,
    MasslessLinkError,
    ModelStructureError,
    ModelWarning,
)
from harness.models.resolve import PackageMap
from harness.models.urdf import (
    REPAIR_BOUNDINERTIA,
    REPAIR_BOUNDMASS,
    harness_extension,
    mujoco_urdf_xml,
    urdf_from_element,
)
from harness.models.xmlsafe import describe, read_xml_file

__all__ = [
    "DEMO_URDF",
    "SCENES",
    "LoadedRobot",
    "load_description",
    "load_robot",
]

DATA = Path(__file__).resolve().parent / "data"
DEMO_URDF = DATA / "demo_arm.urdf"
"""The bundled demo robot (Panda kinematics and limits, two-finger gripper). Its ``home``
keyframe and joint armature are in the file (``<harness>``), so any copy loads the same."""
SCENES: Mapping[str, Path] = MappingProxyType(
    {name: DATA / "scenes" / f"{name}.xml" for name in ("floor", "empty", "table")}
)
"""Named scenes: ``floor`` (what ``scene=None`` gives a URDF/SDF robot), ``empty`` (floor and
light), ``table`` (floor, light, a table and a free box within the demo arm's reach)."""
URDF_SUFFIXES = (".urdf",)
MJCF_SUFFIXES = (".xml", ".mjcf")
SDF_SUFFIXES = (".sdf", ".world")

# Default gains: a position servo saturates its effort limit at this error, a velocity servo
# at this speed error; both are capped so that sqrt(kp / M) * dt <= 0.5 and kv * dt <= M,
# with M the joint's smallest effective inertia (other joints free: 1 / dof_invweight0).
# Reference: kp 2e4 critically damped tracked a Panda well, kp 1e6 was unstable.
#
# A position servo is critically damped for the inertia the joint sees when the other joints
# are held (the mass matrix diagonal, armature included, at the "home" keyframe or the zero
# configuration). Part of that damping is the drive's torque-speed limit, effort / velocity
# (a motor's torque falls linearly to zero at its no-load speed), put on the joint as
# damping so that it acts outside the actuator's force range: a saturated servo then runs at
# about the velocity limit and can brake, instead of reaching many times the limit and
# overshooting it (issue 2: joint7 reached 29x its velocity limit and 0.40 rad past its limit).
_POSITION_SATURATION_ERROR = 0.005
_VELOCITY_SATURATION_ERROR = 0.05
_DEFAULT_EFFORT = 100.0
_STABLE_OMEGA_DT = 0.5


@dataclass(frozen=True)
class LoadedRobot:
    """A robot compiled into MuJoCo, with its description and everything needed to record it.

    ``control`` holds every controllable joint's mode; ``actuated`` the joint driven by each
    actuator index (actuators are named after their joint); ``kinematic`` the joints the
    simulation writes directly. ``mjcf`` is the compiled model saved as MJCF (MuJoCo writes
    6 significant digits: for humans and viewers); ``mjb`` the exact binary model
    (``mj_saveModel``), the one to replay from. ``sources`` maps ``"<role>/<file name>"``
    (roles: model, srdf, scene) to the file bytes; ``sha256`` is of ``mjcf``; ``repairs``
    lists every mass/inertia change made by ``repair_inertia``.
    """

    name: str
    description: RobotModel
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    control: Mapping[str, ControlMode]
    actuated: tuple[str, ...]
    kinematic: tuple[str, ...]
    mjcf: str
    mjb: bytes
    sources: Mapping[str, bytes]
    sha256: str
    repairs: tuple[str, ...] = ()


def _kind(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix in URDF_SUFFIXES:
        return "urdf"
    if suffix in MJCF_SUFFIXES:
        return "mjcf"
    if suffix in SDF_SUFFIXES:
        return "sdf"
    raise ModelStructureError(
        f"{path}: unknown model format {path.suffix!r} (expected .urdf, .sdf, .world, .xml, .mjcf)"
    )


def _source_path(source: str | Path) -> Path:
    if str(source) == "demo":
        return DEMO_URDF
    path = Path(source)
    if not path.is_file():
        raise ModelStructureError(f"{path}: model file not found")
    return path


def _sdf_api() -> tuple[Callable[..., RobotModel], Callable[[RobotModel], mujoco.MjSpec]]:
    try:
        sdf: object = importlib.import_module("harness.models.sdf")
    except ImportError:
        sdf = None
    read = getattr(sdf, "read_sdf", None)
    build = getattr(sdf, "build_spec", None)
    if read is None or build is None:
        raise ModelStructureError("SDF is not available yet (harness.models.sdf is missing)")
    return read, build


def load_description(source: str | Path) -> RobotModel:
    """The :class:`RobotModel` of ``source`` ("demo", .urdf, .sdf/.world, MJCF) without
    building the MuJoCo model for URDF and SDF (MJCF is compiled to read it)."""
    path = _source_path(source)
    kind = _kind(path)
    if kind == "urdf":
        root, _ = read_xml_file(path)
        return urdf_from_element(root, str(path))
    if kind == "sdf":
        read_sdf, _ = _sdf_api()
        return read_sdf(path)
    read_xml_file(path)  # safety and well-formedness before MuJoCo's parser sees it
    spec = _spec_from_file(path)
    return _describe_mjcf(_compile(spec, str(path)), path)


def _describe_mjcf(model: mujoco.MjModel, path: Path) -> RobotModel:
    from harness.models.mjcf import description_from_model

    return description_from_model(model, path.stem, str(path))


def _spec_from_file(path: Path) -> mujoco.MjSpec:
    try:
        with _mujoco_warnings():
            return mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise CompileError(f"{path}: {_mujoco_message(exc)}") from None


def _spec_from_string(xml: str, source: str) -> mujoco.MjSpec:
    try:
        with _mujoco_warnings():
            return mujoco.MjSpec.from_string(xml)
    except ValueError as exc:
        raise CompileError(f"{source}: {_mujoco_message(exc)}") from None


def _mujoco_message(exc: Exception) -> str:
    return " ".join(str(exc).replace("Error:", "").split())


_MASSLESS = re.compile(r"mass and inertia of moving bodies.*?Element name '([^']*)'", re.S)


def _compile(spec: mujoco.MjSpec, source: str) -> mujoco.MjModel:
    try:
        with _mujoco_warnings():
            return spec.compile()
    except ValueError as exc:
        text = str(exc)
        match = _MASSLESS.search(text)
        if match:
            raise MasslessLinkError(
                f'{source}: <link name="{match.group(1)}">: moving link has no mass or '
                "inertia (fix the <inertial>, or load with repair_inertia=True)"
            ) from None
        raise CompileError(f"{source}: {_mujoco_message(exc)}") from None


@contextmanager
def _mujoco_warnings() -> Iterator[None]:
    """Re-issue MuJoCo's printed warnings as :class:`ModelWarning`; drop the one about
    attaching with an empty prefix (robot names stay unprefixed on purpose: one robot)."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")
            yield
    finally:
        mujoco.set_mju_user_warning(previous)
    for message in messages:
        if "empty prefix" not in message:
            warnings.warn(" ".join(message.split()), ModelWarning, stacklevel=4)


def _resolve_control(
    description: RobotModel,
    joint_names: set[str],
    control: ControlMode | Mapping[str, ControlMode],
    source: str,
) -> dict[str, ControlMode]:
    controllable = [j.name for j in description.controllable_joints if j.name in joint_names]
    if isinstance(control, str):
        _check_mode(control, "control")
        return {name: control for name in controllable}
    unknown = sorted(set(control) - set(controllable))
    if unknown:
        raise ModelStructureError(
            f"{source}: control names joints that are not controllable joints of the robot: "
            f"{unknown} (controllable: {controllable})"
        )
    modes: dict[str, ControlMode] = {}
    for name in controllable:
        mode = control.get(name, "position")
        _check_mode(mode, f"control[{name!r}]")
        modes[name] = mode
    return modes


def _check_mode(mode: object, where: str) -> None:
    if mode not in CONTROL_MODES:
        raise ModelStructureError(
            f"{where}: unknown control mode {mode!r} (expected one of {', '.join(CONTROL_MODES)})"
        )


def _held_inertia(model: mujoco.MjModel, qpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Per dof, the inertia it sees with every other dof held: the mass matrix diagonal."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    diagonal: npt.NDArray[np.float64] = np.diag(full).copy()
    return diagonal


def _add_actuators(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    description: RobotModel,
    modes: Mapping[str, ControlMode],
    gains: Mapping[str, float],
    held_inertia: npt.NDArray[np.float64],
) -> tuple[str, ...]:
    dt = float(model.opt.timestep)
    actuated = []
    for name, mode in modes.items():
        if mode == "kinematic":
            continue
        joint = description.joint(name)
        limits = joint.limits
        effort = limits.effort if limits.effort is not None and limits.effort > 0 else None
        dof = int(model.jnt_dofadr[model.joint(name).id])
        # the smallest effective inertia (other joints free to move): the stability bound
        inertia = 1.0 / float(model.dof_invweight0[dof])
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if mode == "position":
            kp = gains.get(name)
            if kp is None:
                kp = (effort or _DEFAULT_EFFORT) / _POSITION_SATURATION_ERROR
                kp = min(kp, inertia * (_STABLE_OMEGA_DT / dt) ** 2)
            spec_joint = spec.joint(name)
            damping = float(spec_joint.damping[0])
            if effort is not None and limits.velocity is not None and limits.velocity > 0:
                damping += effort / limits.velocity
                spec_joint.damping = [damping, *spec_joint.damping[1:]]
            critical = 2.0 * float(np.sqrt(kp * held_inertia[dof]))
            act.set_to_position(kp=float(kp), kv=max(critical - damping, 0.0))
            lower, upper = limits.lower, limits.upper
            bounded = lower is not None and upper is not None and lower < upper
            if bounded and joint.type != "continuous":
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [lower, upper]
        elif mode == "velocity":
            kv = gains.get(name)
            if kv is None:
                kv = (effort or _DEFAULT_EFFORT) / _VELOCITY_SATURATION_ERROR
                kv = min(kv, inertia / dt)
            act.set_to_velocity(kv=float(kv))
            if limits.velocity is not None and limits.velocity > 0:
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [-limits.velocity, limits.velocity]
        else:
            act.set_to_motor()
            if effort is not None:
                act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.ctrlrange = [-effort, effort]
        if mode in ("position", "velocity") and effort is not None:
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-effort, effort]
        actuated.append(name)
    return tuple(actuated)


def _add_srdf_excludes(spec: mujoco.MjSpec, srdf: Path, body_names: set[str]) -> bytes:
    root, raw = read_xml_file(srdf)
    for element in root.iter("disable_collisions"):
        link1, link2 = element.get("link1"), element.get("link2")
        for link in (link1, link2):
            if not link or link not in body_names:
                raise ModelStructureError(
                    f"{srdf}: {describe(element)}: link {link!r} is not a body of the model"
                )
        spec.add_exclude(bodyname1=link1, bodyname2=link2)
    return raw


def _scene_spec(scene: str | Path | None, source: str) -> tuple[mujoco.MjSpec, Path]:
    if scene is None:
        scene = "floor"
    path = SCENES.get(str(scene)) if isinstance(scene, str) else None
    if path is None:
        path = Path(scene)
        if not path.is_file():
            raise ModelStructureError(
                f"{source}: scene {str(scene)!r} is neither a file nor one of {sorted(SCENES)}"
            )
    read_xml_file(path)
    return _spec_from_file(path), path


def _repairs(
    model: mujoco.MjModel,
    description: RobotModel,
    repaired_inertias: Mapping[str, tuple[float, ...]],
) -> tuple[str, ...]:
    """The links whose mass or inertia the compiler bounds or balancing changed."""
    found = []
    for link in description.links:
        body = model.body(link.name) if _has_body(model, link.name) else None
        if body is None or body.id == 0:
            continue
        mass = float(model.body_mass[body.id])
        inertia = model.body_inertia[body.id]
        source_mass = link.inertial.mass if link.inertial else 0.0
        if mass == REPAIR_BOUNDMASS and source_mass < REPAIR_BOUNDMASS:
            found.append(
                f"{link.name}: mass {source_mass:g} -> {REPAIR_BOUNDMASS:g} kg (boundmass)"
            )
        if any(float(v) == REPAIR_BOUNDINERTIA for v in inertia):
            found.append(
                f"{link.name}: principal inertia raised to {REPAIR_BOUNDINERTIA:g} kg m^2 "
                "(boundinertia)"
            )
        elif link.inertial is not None and link.inertial.mass > 0:
            ixx, ixy, ixz, iyy, iyz, izz = repaired_inertias.get(link.name, link.inertial.inertia)
            tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            expected = np.sort(np.linalg.eigvalsh(tensor))
            actual = np.sort(np.asarray(inertia, dtype=float))
            if not np.allclose(expected, actual, rtol=1e-6, atol=1e-12):
                found.append(
                    f"{link.name}: inertia {np.round(expected, 9).tolist()} -> "
                    f"{np.round(actual, 9).tolist()} (balanceinertia)"
                )
    return tuple(found)


def _has_body(model: mujoco.MjModel, name: str) -> bool:
    return bool(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0)


def _key_qpos(model: mujoco.MjModel, values: Mapping[str, float]) -> npt.NDArray[np.float64]:
    qpos = np.array(model.qpos0, dtype=float)
    for name, value in values.items():
        qpos[model.jnt_qposadr[model.joint(name).id]] = value
    return qpos


def _servo_configuration(
    model: mujoco.MjModel, keyframes: Mapping[str, Mapping[str, float]]
) -> npt.NDArray[np.float64]:
    """Where the servos are tuned: the ``home`` keyframe (the source's own or the URDF's
    ``<harness>`` one), else the zero configuration."""
    if "home" in keyframes:
        return _key_qpos(model, keyframes["home"])
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    if key >= 0:
        return np.array(model.key_qpos[key], dtype=float)
    return np.array(model.qpos0, dtype=float)


def _add_keyframes(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    keyframes: Mapping[str, Mapping[str, float]],
    actuated: tuple[str, ...],
    modes: Mapping[str, ControlMode],
) -> None:
    """Each keyframe as a MuJoCo key: its joint positions (others at qpos0) and, for
    position servos, the same positions as their targets."""
    for key, values in keyframes.items():
        qpos = _key_qpos(model, values)
        ctrl = [
            float(qpos[model.jnt_qposadr[model.joint(name).id]])
            if modes.get(name) == "position"
            else 0.0
            for name in actuated
        ]
        spec.add_key(name=key, qpos=qpos.tolist(), ctrl=ctrl)


def load_robot(
    source: str | Path = "demo",
    *,
    control: ControlMode | Mapping[str, ControlMode] = "position",
    scene: str | Path | None = None,
    packages: PackageMap | None = None,
    srdf: str | Path | None = None,
    visuals: bool = False,
    repair_inertia: bool = False,
    gains: Mapping[str, float] | None = None,
    cache_dir: str | Path | None = None,
) -> LoadedRobot:
    """Load ``source`` into MuJoCo with one actuator per controllable joint.

    ``source``: ``"demo"`` (default scene ``"table"``), or a .urdf, .sdf/.world or MJCF
    (.xml/.mjcf, taken as is: its own actuators are kept, others are added only when it has
    none, and it gets a scene only when one is asked for). ``control``: one mode for every
    controllable joint or a mapping joint -> mode (unlisted joints: ``"position"``).
    ``scene``: None (a floor), ``"floor"``, ``"empty"``, ``"table"`` or an MJCF world file.
    ``packages``: package name -> folder for ``package://``. ``srdf``: its
    ``<disable_collisions>`` become body-pair excludes. ``visuals``: keep visual geoms
    (non-colliding). ``repair_inertia``: bound masses/inertias and balance inertias,
    reporting every changed link in ``repairs``. ``gains``: joint -> kp (position) or kv
    (velocity) overriding the defaults. ``cache_dir``: converted-mesh cache folder.

    A URDF's ``<harness>`` element adds keyframes and joint armature (see
    :func:`harness.models.urdf.harness_extension`): the model depends on file contents only,
    never on where the file is. Position servos are critically damped (servo kv plus joint
    damping) for the inertia each joint sees with the others held, at the ``home`` keyframe;
    their joint gets the drive's torque-speed limit, effort / velocity, as extra damping, so a
    saturated servo moves at about its velocity limit and stops at its target.
    """
    path = _source_path(source)
    name_of_source = str(path)
    kind = _kind(path)
    sources: dict[str, bytes] = {}
    if str(source) == "demo" and scene is None:
        scene = "table"

    existing_actuators = False
    keyframes: Mapping[str, Mapping[str, float]] = {}
    source_repairs: tuple[str, ...] = ()
    repaired_inertias: Mapping[str, tuple[float, ...]] = {}
    if kind == "urdf":
        root, raw = read_xml_file(path)
        sources[f"model/{path.name}"] = raw
        description = urdf_from_element(root, name_of_source)
        prepared = mujoco_urdf_xml(
            root,
            path,
            packages=packages,
            visuals=visuals,
            repair_inertia=repair_inertia,
            cache_dir=cache_dir,
        )
        source_repairs, repaired_inertias = prepared.repairs, prepared.inertias
        robot_spec = _spec_from_string(prepared.xml, name_of_source)
        extension = harness_extension(root, description)
        keyframes = extension.keyframes
        for joint_name, armature in extension.armature.items():
            robot_spec.joint(joint_name).armature = armature
    elif kind == "sdf":
        read_sdf, build_spec = _sdf_api()
        sources[f"model/{path.name}"] = path.read_bytes()
        description = read_sdf(path)
        robot_spec = build_spec(description)
    else:
        _, raw = read_xml_file(path)
        sources[f"model/{path.name}"] = raw
        robot_spec = _spec_from_file(path)
        description = _describe_mjcf(_compile(robot_spec.copy(), name_of_source), path)
        existing_actuators = len(robot_spec.actuators) > 0

    if kind == "mjcf" and scene is None:
        spec = robot_spec
    else:
        spec, scene_path = _scene_spec(scene, name_of_source)
        sources[f"scene/{scene_path.name}"] = scene_path.read_bytes()
        frame = spec.worldbody.add_frame()
        with _mujoco_warnings():
            spec.attach(robot_spec, prefix="", frame=frame)
    spec.modelname = description.name

    first = _compile(spec, name_of_source)
    joint_names = {first.joint(j).name for j in range(first.njnt)}
    if existing_actuators:
        modes, actuated = _existing_control(first)
    else:
        modes = _resolve_control(description, joint_names, control, name_of_source)
        unknown_gains = sorted(set(gains or {}) - set(modes))
        if unknown_gains:
            raise ModelStructureError(
                f"{name_of_source}: gains name joints that are not controllable: {unknown_gains}"
            )
        held = _held_inertia(first, _servo_configuration(first, keyframes))
        actuated = _add_actuators(spec, first, description, modes, dict(gains or {}), held)
    if srdf is not None:
        body_names = {first.body(b).name for b in range(first.nbody)}
        sources[f"srdf/{Path(srdf).name}"] = _add_srdf_excludes(spec, Path(srdf), body_names)
    _add_keyframes(spec, first, keyframes, actuated, modes)

    model = _compile(spec, name_of_source)
    with _mujoco_warnings():
        mjcf = spec.to_xml()
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return LoadedRobot(
        name=description.name,
        description=description,
        spec=spec,
        model=model,
        control=MappingProxyType(modes),
        actuated=actuated,
        kinematic=tuple(n for n, m in modes.items() if m == "kinematic"),
        mjcf=mjcf,
        mjb=buffer.tobytes(),
        sources=MappingProxyType(sources),
        sha256=hashlib.sha256(mjcf.encode()).hexdigest(),
        repairs=(
            source_repairs + _repairs(model, description, repaired_inertias)
            if repair_inertia
            else ()
        ),
    )


def _existing_control(model: mujoco.MjModel) -> tuple[dict[str, ControlMode], tuple[str, ...]]:
    """Control modes of an MJCF's own joint actuators, inferred from gain and bias."""
    modes: dict[str, ControlMode] = {}
    actuated = []
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        joint = model.joint(int(model.actuator_trnid[a][0])).name
        bias: Any = model.actuator_biasprm[a]
        mode: ControlMode = "effort"
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            mode = "position" if bias[1] != 0 else "velocity"
        modes[joint] = mode
        actuated.append(joint)
    return modes, tuple(actuated)
