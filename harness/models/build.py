"""``load_robot``: a robot description (URDF, SDF, MJCF or the bundled demo) into MuJoCo.

URDF goes through MuJoCo's own URDF importer (mesh URIs resolved and converted first, a
``<mujoco><compiler fusestatic="false" .../>`` element so every link stays a named body), then
one actuator per controllable joint, SRDF collision exclusions, the scene, compile.

Every file a model uses (meshes of any format, MJCF textures, height fields, skins, the
scene's) enters the spec as an in-memory asset named by its content
(:mod:`harness.models.assets`): the compiled model is the same byte for byte whichever folder
the project, the venv, the robot package or the mesh cache live in.
"""

from __future__ import annotations

import hashlib
import importlib
import math
import re
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models import setup, surfaces
from harness.models.assets import embed_files
from harness.models.description import ControlMode, Pose, RobotModel
from harness.models.drive_plugins import plugin_modes, plugin_wheels
from harness.models.drives import COMMAND_FILTER_SECONDS
from harness.models.errors import (
    CompileError,
    MasslessLinkError,
    ModelStructureError,
    ModelWarning,
)
from harness.models.lenient import lenient_urdf
from harness.models.limits import check_description, check_spec, check_urdf_counts
from harness.models.mjcf_files import check_mjcf_files
from harness.models.passive import declared_actuated, drop_passive
from harness.models.resolve import PackageMap
from harness.models.ros2_control import warn_replaced_hardware
from harness.models.selfcollision import declared_link_self_collide, declared_self_collide
from harness.models.urdf import (
    REPAIR_BOUNDINERTIA,
    REPAIR_BOUNDMASS,
    harness_extension,
    mujoco_urdf_xml,
)
from harness.models.urdf_source import (
    control_defaults,
    describe_urdf,
    initial_keyframes,
    locate,
    read_urdf_source,
)
from harness.models.world import (
    BaseKind,
    DuplicateNamespaceError,
    JointAddress,
    LoadedRobotView,
    LoadedWorld,
    PoseLike,
    RobotSpec,
    SelfCollision,
    SelfCollisionReport,
    WorldObject,
    check_namespace,
    placement_pose,
)
from harness.models.xacro import RobotArgs, is_xacro
from harness.models.xmlsafe import describe, read_xml_file

__all__ = [
    "DEMO_URDF",
    "SCENES",
    "LoadedRobot",
    "load_description",
    "load_robot",
    "load_world",
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
    lists every mass/inertia change made by ``repair_inertia``; ``notes`` what a lenient load
    recovered and how the robot was placed; ``self_collision`` the policy and the ignored link
    pairs; ``base`` fixed or floating; ``placement`` where the model frame is in the world
    (the ``pose`` asked for, lifted out of the floor if need be). ``spec`` carries the mesh and
    texture files in ``spec.assets`` (content-named): it compiles without the files.
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
    notes: tuple[str, ...] = ()
    self_collision: SelfCollisionReport | None = None
    base: BaseKind = "fixed"
    placement: Pose = field(default_factory=Pose)


def _kind(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix in URDF_SUFFIXES or is_xacro(path):
        return "urdf"
    if suffix in MJCF_SUFFIXES:
        return "mjcf"
    if suffix in SDF_SUFFIXES:
        return "sdf"
    raise ModelStructureError(
        f"{path}: unknown model format {path.suffix!r} (expected .urdf, .xacro, .sdf, .world, "
        ".xml, .mjcf)"
    )


def _source_path(source: str | Path, packages: PackageMap | None = None) -> Path:
    if str(source) == "demo":
        return DEMO_URDF
    return locate(source, packages)


def _sdf_api() -> tuple[Callable[..., RobotModel], Callable[..., mujoco.MjSpec]]:
    try:
        sdf: object = importlib.import_module("harness.models.sdf")
    except ImportError:
        sdf = None
    read = getattr(sdf, "read_sdf", None)
    build = getattr(sdf, "build_spec", None)
    if read is None or build is None:
        raise ModelStructureError("SDF is not available yet (harness.models.sdf is missing)")
    return read, build


def load_description(
    source: str | Path,
    *,
    robot_args: RobotArgs | None = None,
    packages: PackageMap | None = None,
    strict: bool = False,
) -> RobotModel:
    """The :class:`RobotModel` of ``source`` ("demo", .urdf, .xacro with ``robot_args``,
    ``package://``, .sdf/.world, MJCF) without building the MuJoCo model for URDF and SDF
    (MJCF is compiled to read it). ``strict``: as for :func:`load_robot`."""
    path = _source_path(source, packages)
    kind = _kind(path)
    if kind == "urdf":
        urdf = read_urdf_source(
            path, robot_args=robot_args, packages=packages, reference=str(source), strict=strict
        )
        lenient_urdf(urdf.root, str(path), strict=strict)
        return describe_urdf(urdf.root, str(path), urdf.origin)
    if kind == "sdf":
        read_sdf, _ = _sdf_api()
        return read_sdf(path, strict=strict)
    read_xml_file(path)  # safety and well-formedness before MuJoCo's parser sees it
    spec = _spec_from_file(path)
    return _describe_mjcf(_compile(spec, str(path)), path)


def _describe_mjcf(model: mujoco.MjModel, path: Path) -> RobotModel:
    from harness.models.mjcf import description_from_model

    return description_from_model(model, path.stem, str(path))


def _spec_from_file(path: Path) -> mujoco.MjSpec:
    check_mjcf_files(path)  # before MuJoCo opens its includes and assets
    try:
        with _mujoco_warnings():
            return mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise CompileError(f"{path}: {_mujoco_message(exc)}") from None


def _spec_from_string(
    xml: str, source: str, assets: Mapping[str, bytes] | None = None
) -> mujoco.MjSpec:
    try:
        with _mujoco_warnings():
            return mujoco.MjSpec.from_string(xml, assets=dict(assets or {}))
    except ValueError as exc:
        raise CompileError(f"{source}: {_mujoco_message(exc)}") from None


def _mujoco_message(exc: Exception) -> str:
    return " ".join(str(exc).replace("Error:", "").split())


_MASSLESS = re.compile(r"mass and inertia of moving bodies.*?Element name '([^']*)'", re.S)


def _compile(spec: mujoco.MjSpec, source: str, *, check: bool = True) -> mujoco.MjModel:
    if check:
        check_spec(spec, source)  # before the compiler allocates what the model declares
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
        triangle = _TRIANGLE.search(text)
        if triangle:
            raise CompileError(
                f'{source}: <link name="{triangle.group(1)}">: inertia violates the triangle '
                "inequality (A + B >= C) (load without strict=True to have it repaired)"
            ) from None
        raise CompileError(f"{source}: {_mujoco_message(exc)}") from None


_TRIANGLE = re.compile(r"inertia must satisfy A \+ B >= C.*?Element name '([^']*)'", re.S)
_MESH_VOLUME = re.compile(r"mesh volume is too small: (\S+)")


def _compile_lenient(spec: mujoco.MjSpec, source: str, robots: Sequence[_Robot]) -> mujoco.MjModel:
    """Compile; a mesh too thin for MuJoCo's volume-based inertia gets shell inertia (its
    body's inertia comes from the file's ``<inertial>`` anyway), with a note, unless strict."""
    strict = any(r.request.strict for r in robots)
    # the limits once, before the first compile: after a failed compile the spec's tree
    # reports that compile's error when read, whatever was changed since
    check_spec(spec, source)
    for _ in range(64):
        try:
            return _compile(spec, source, check=False)
        except CompileError as exc:
            match = _MESH_VOLUME.search(str(exc))
            mesh = None if match is None or strict else spec.mesh(match.group(1))
            if mesh is None or mesh.inertia == mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL:
                raise
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            robots[0].notes.append(
                f"{source}: mesh {match.group(1) if match else ''} encloses (almost) no volume: "
                "its inertia is computed as a shell"
            )
    return _compile(spec, source, check=False)


# An attached MJCF robot's <size> memory hints (nkey: it brings keyframes) lose to the world's:
# harmless, unlike other attach conflicts (an ignored <option timestep>).
_SIZE_HINT_CONFLICT = (
    r"\s*Attach conflict[^\n]*"
    r"(\n(nkey|nuserdata|nuser_\w+|memory|nconmax|njmax|nstack):[^\n]*)+\s*$"
)


@contextmanager
def _mujoco_warnings() -> Iterator[None]:
    """Re-issue MuJoCo's warnings (printed or Python) as :class:`ModelWarning`; drop the one
    about attaching with an empty prefix (robot names stay unprefixed on purpose: one robot)
    and attach conflicts about size hints only."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        mujoco.set_mju_user_warning(previous)
    # the printed attach conflict is a headline only: its Python twin has the details
    messages = [m for m in messages if not m.lstrip().startswith("Attach conflict")]
    for warning in caught:
        text = str(warning.message)
        if "empty prefix" in text or re.match(_SIZE_HINT_CONFLICT, text):
            continue
        if text.lstrip().startswith("Attach conflict"):
            messages.append(text)
        else:
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    for message in messages:
        if "empty prefix" not in message:
            warnings.warn(" ".join(message.split()), ModelWarning, stacklevel=4)


def _resolve_control(
    description: RobotModel,
    joint_names: set[str],
    control: ControlMode | str | Mapping[str, ControlMode | str],
    source: str,
) -> dict[str, ControlMode]:
    controllable = [j.name for j in description.controllable_joints if j.name in joint_names]
    if isinstance(control, str):
        mode = _check_mode(control, "control")
        return dict.fromkeys(controllable, mode)
    unknown = sorted(set(control) - set(controllable))
    if unknown:
        raise ModelStructureError(
            f"{source}: control names joints that are not controllable joints of the robot: "
            f"{unknown} (controllable: {controllable})"
        )
    modes: dict[str, ControlMode] = {}
    for name in controllable:
        modes[name] = _check_mode(control.get(name, ControlMode.POSITION), f"control[{name!r}]")
    return modes


def _check_mode(mode: object, where: str) -> ControlMode:
    try:
        return ControlMode.parse(mode, where)
    except ValueError as exc:
        raise ModelStructureError(str(exc)) from None


def _held_inertia(model: mujoco.MjModel, qpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Per dof, the inertia it sees with every other dof held: the mass matrix diagonal."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    # The diagonal straight from the sparse rows (the last entry of each lower-triangle row):
    # the dense nv x nv matrix was quadratic in the number of joints (200 MB at 5,000).
    diagonal: npt.NDArray[np.float64] = data.M[model.M_rowadr + model.M_rownnz - 1].copy()
    return diagonal


def _drive_armature(kp: float, inertia: float, dt: float) -> float:
    """The reflected rotor inertia a geared drive needs to servo at stiffness ``kp`` stably
    (``sqrt(kp / (inertia + armature)) * dt <= 0.5``), for a joint whose file states none:
    the link inertia alone (``inertia``, the smallest the joint sees) is what a motor without
    a gearbox would move. Real gearboxes reflect rotor inertia times the square of the ratio
    (0.01 to 1 kg m^2 for arm joints); 0 when the link inertia is already enough."""
    needed = kp / (_STABLE_OMEGA_DT / dt) ** 2
    return max(0.0, needed - inertia)


def _add_actuators(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    description: RobotModel,
    modes: Mapping[str, ControlMode],
    gains: Mapping[str, float],
    held_inertia: npt.NDArray[np.float64],
    prefix: str = "",
) -> tuple[str, ...]:
    """One actuator per non-kinematic joint of ``modes`` (unprefixed names), named after its
    MuJoCo joint ``prefix + name``; returns the actuated joints (unprefixed) in order."""
    dt = float(model.opt.timestep)
    actuated = []
    for name, mode in modes.items():
        if mode == "kinematic":
            continue
        joint = description.joint(name)
        limits = joint.limits
        effort = limits.effort if limits.effort is not None and limits.effort > 0 else None
        mj_name = prefix + name
        dof = int(model.jnt_dofadr[model.joint(mj_name).id])
        # the smallest effective inertia (other joints free to move): the stability bound
        inertia = 1.0 / float(model.dof_invweight0[dof])
        act = spec.add_actuator(name=mj_name, target=mj_name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if mode == "position":
            kp = gains.get(name)
            spec_joint = spec.joint(mj_name)
            held_dof = float(held_inertia[dof])
            if kp is None:
                kp = (effort or _DEFAULT_EFFORT) / _POSITION_SATURATION_ERROR
                added = _drive_armature(kp, inertia, dt) if spec_joint.armature == 0 else 0.0
                if added > 0.0:
                    spec_joint.armature = added
                    inertia += added
                    held_dof += added
                kp = min(kp, inertia * (_STABLE_OMEGA_DT / dt) ** 2)
            damping = float(spec_joint.damping[0])
            if effort is not None and limits.velocity is not None and limits.velocity > 0:
                damping += effort / limits.velocity
                spec_joint.damping = [damping, *spec_joint.damping[1:]]
            critical = 2.0 * float(np.sqrt(kp * held_dof))
            act.set_to_position(
                kp=float(kp), kv=max(critical - damping, 0.0), timeconst=COMMAND_FILTER_SECONDS
            )
            act.actearly = True  # the force uses the filtered command of this very step
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


def _add_srdf_excludes(
    spec: mujoco.MjSpec, srdf: Path, body_names: set[str], prefix: str = ""
) -> tuple[bytes, tuple[tuple[str, str], ...]]:
    root, raw = read_xml_file(srdf)
    pairs = []
    for element in root.iter("disable_collisions"):
        link1, link2 = element.get("link1"), element.get("link2")
        for link in (link1, link2):
            if not link or link not in body_names:
                raise ModelStructureError(
                    f"{srdf}: {describe(element)}: link {link!r} is not a body of the model"
                )
        spec.add_exclude(bodyname1=prefix + str(link1), bodyname2=prefix + str(link2))
        pairs.append((str(link1), str(link2)))
    return raw, tuple(pairs)


def _scene_spec(
    scene: str | Path | None, source: str, cache_dir: str | Path | None
) -> tuple[mujoco.MjSpec, Path, dict[str, bytes]]:
    """The scene's spec, its file and its sources (an SDF world: every file it reads)."""
    if scene is None:
        scene = "floor"
    path = SCENES.get(str(scene)) if isinstance(scene, str) else None
    if path is None:
        path = Path(scene)
        if not path.is_file():
            raise ModelStructureError(
                f"{source}: scene {str(scene)!r} is neither a file nor one of {sorted(SCENES)}"
            )
    from harness.models import worldfile  # imports the SDF reader: only when a world is used

    if worldfile.is_sdf_world(path):
        world = worldfile.load_world_file(path, cache_dir=cache_dir)
        return world.spec, path, dict(world.sources)
    read_xml_file(path)
    spec = _spec_from_file(path)
    embed_files(spec, source=str(path), cache_dir=cache_dir)
    return spec, path, {f"scene/{path.name}": path.read_bytes()}


def _repairs(
    model: mujoco.MjModel,
    description: RobotModel,
    repaired_inertias: Mapping[str, tuple[float, ...]],
    prefix: str = "",
) -> tuple[str, ...]:
    """The links whose mass or inertia the compiler bounds or balancing changed."""
    found = []
    for link in description.links:
        name = prefix + link.name
        body = model.body(name) if _has_body(model, name) else None
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


class _Robot:
    """A robot being assembled: its source read, its spec built, its names not yet in a world."""

    def __init__(self, index: int, robot: RobotSpec, cache_dir: str | Path | None) -> None:
        self.index = index
        self.request = robot
        self.namespace = ""
        self.prefix = ""
        self.path = _source_path(robot.source, robot.packages)
        self.source = str(self.path)
        self.kind = _kind(self.path)
        self.model_bytes = b""
        self.extra_sources: Mapping[str, bytes] = {}  # a xacro robot's files read and meshes
        self.existing_actuators = False
        # key name -> joint -> position, from a URDF's <harness> element
        self.extension_keys: Mapping[str, Mapping[str, float]] = {}
        self.spec_keys: tuple[str, ...] = ()  # keys the robot's own spec brings (MJCF)
        self.source_repairs: tuple[str, ...] = ()
        self.repaired_inertias: Mapping[str, tuple[float, ...]] = {}
        self.modes: dict[str, ControlMode] = {}
        self.actuated: tuple[str, ...] = ()
        self.srdf_bytes: bytes | None = None
        self.srdf_pairs: tuple[tuple[str, str], ...] = ()
        self.repairs_made: tuple[str, ...] = ()
        self.notes: list[str] = []
        self.declared_self_collide: bool | None = None
        self.link_self_collide: dict[str, bool] = {}
        self.frame: Any = None
        self.base: BaseKind = "fixed"
        self.self_collision: SelfCollisionReport | None = None
        self.repair = robot.repair_inertia and not robot.strict
        self.plugin_wheels: tuple[str, ...] = ()  # joints a file's drive plugin drives
        self.declared_actuated: frozenset[str] = frozenset()  # see harness.models.passive
        setup.check_options(robot, self.source)
        path = self.path
        if self.kind == "urdf":
            urdf = read_urdf_source(
                path, robot_args=robot.robot_args, packages=robot.packages,
                reference=str(robot.source), strict=robot.strict,
            )  # fmt: skip
            root, self.model_bytes, self.extra_sources = urdf.root, urdf.data, urdf.extra
            self.path = urdf.path  # a xacro robot is recorded as its expanded URDF
            check_urdf_counts(root, self.source)
            notes = [*urdf.notes, *lenient_urdf(root, self.source, strict=robot.strict)]
            self.notes.extend(str(n) for n in notes)
            self.declared_self_collide = declared_self_collide(root)
            self.link_self_collide = declared_link_self_collide(root)
            self.description = describe_urdf(root, self.source, urdf.origin)
            warn_replaced_hardware(self.description.ros2_control, self.source)
            check_description(self.description, self.source)  # before MuJoCo reads the tree
            prepared = mujoco_urdf_xml(
                root,
                path,
                packages=robot.packages,
                visuals=robot.visuals,
                repair_inertia=self.repair,
                cache_dir=cache_dir,
            )
            self.source_repairs, self.repaired_inertias = prepared.repairs, prepared.inertias
            self.spec = _spec_from_string(prepared.xml, self.source, prepared.assets)
            extension = harness_extension(root, self.description)
            self.extension_keys = initial_keyframes(extension.keyframes, self.description)
            for joint_name, armature in extension.armature.items():
                self.spec.joint(joint_name).armature = armature
            surfaces.apply_frictions(
                self.spec, surfaces.gazebo_frictions(root, self.source), self.source
            )
            self.plugin_wheels = plugin_wheels(root)
            self.declared_actuated = declared_actuated(root, self.description, self.plugin_wheels)
            if robot.base == "floating":
                if any(link.name == "world" for link in self.description.links):
                    raise ModelStructureError(
                        f"{self.source}: base='floating' but the URDF fixes the robot to a "
                        "link named 'world'"
                    )
                setup.make_floating(self.spec, self.source)
                self.base = "floating"
        elif self.kind == "sdf":
            read_sdf, build_spec = _sdf_api()
            self.model_bytes = path.read_bytes()
            self.description = read_sdf(path, strict=robot.strict)
            check_description(self.description, self.source)
            self.spec = build_spec(self.description, cache_dir=cache_dir)
            sdf_root = read_xml_file(path)[0]
            self.declared_self_collide = declared_self_collide(sdf_root)
            self.link_self_collide = declared_link_self_collide(sdf_root)
            self.base = setup.sdf_base(self.spec, robot.base)
        else:
            _, self.model_bytes = read_xml_file(path)
            self.spec = _spec_from_file(path)
            embed_files(self.spec, source=self.source, cache_dir=cache_dir)
            self.description = _describe_mjcf(_compile(self.spec.copy(), self.source), path)
            self.existing_actuators = len(self.spec.actuators) > 0
        self.spec_keys = tuple(key.name for key in self.spec.keys)

    def set_namespace(self, namespace: str) -> None:
        self.namespace = namespace
        self.prefix = f"{namespace}/" if namespace else ""

    def where(self, several: bool) -> str:
        return f"robots[{self.index}] ({self.source})" if several else self.source

    def joint_ids(self, model: mujoco.MjModel) -> list[int]:
        """This robot's MuJoCo joints, in model order."""
        names = {self.prefix + j.name for j in self.description.joints}
        return [j for j in range(model.njnt) if model.joint(j).name in names]

    def own_key(self, model: mujoco.MjModel, key: str) -> int:
        """The id of this robot's own attached key ``key`` in ``model`` (-1 if none)."""
        if key not in self.spec_keys:
            return -1
        return int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, self.prefix + key))

    def key_values(
        self, model: mujoco.MjModel, key: str, qpos: npt.NDArray[np.float64]
    ) -> tuple[int, bool]:
        """Write this robot's positions of keyframe ``key`` into ``qpos`` (its ``home`` when
        it has no such key); returns the own attached key used (-1: none) and whether any
        source keyframe was found."""
        for name in (key, "home"):
            if name in self.extension_keys:
                for joint, value in self.extension_keys[name].items():
                    qpos[model.jnt_qposadr[model.joint(self.prefix + joint).id]] = value
                return -1, True
            own = self.own_key(model, name)
            if own >= 0:
                for j in self.joint_ids(model):
                    start, width = _qpos_span(model, j)
                    qpos[start : start + width] = model.key_qpos[own][start : start + width]
                return own, True
        return -1, False


def _qpos_span(model: mujoco.MjModel, joint: int) -> tuple[int, int]:
    start = int(model.jnt_qposadr[joint])
    end = int(model.jnt_qposadr[joint + 1]) if joint + 1 < model.njnt else int(model.nq)
    return start, end - start


def _dof_span(model: mujoco.MjModel, joint: int) -> tuple[int, int]:
    start = int(model.jnt_dofadr[joint])
    end = int(model.jnt_dofadr[joint + 1]) if joint + 1 < model.njnt else int(model.nv)
    return start, end - start


def _place_top_bodies(spec: mujoco.MjSpec, pose: Pose) -> None:
    """Move every top-level body of a world-owning MJCF robot by ``pose`` (bodies in a
    ``<frame>`` move with their frame)."""
    moved: list[Any] = []
    for body in spec.worldbody.bodies:
        frame = body.frame
        target = frame if frame is not None else body
        if any(target is m for m in moved):
            continue
        moved.append(target)
        composed = pose * Pose(
            tuple(float(v) for v in target.pos),  # type: ignore[arg-type]
            tuple(float(v) for v in target.quat),  # type: ignore[arg-type]
        )
        target.pos = list(composed.xyz)
        target.quat = list(composed.quat)


def _add_object(spec: mujoco.MjSpec, obj: WorldObject, where: str) -> None:
    obj.check(where)
    pose = placement_pose(obj.pose, where) or Pose()
    body = spec.worldbody.add_body(name=obj.name, pos=list(pose.xyz), quat=list(pose.quat))
    if obj.mass is not None:
        body.add_freejoint(name=f"{obj.name}_joint")
    shapes = {
        "box": mujoco.mjtGeom.mjGEOM_BOX,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
        "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
        "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    }
    geom = body.add_geom(name=obj.name, type=shapes[obj.shape])
    geom.size = [*obj.size, *([0.0] * (3 - len(obj.size)))]
    if obj.mass is not None:
        geom.mass = obj.mass
    if obj.rgba is not None:
        geom.rgba = list(obj.rgba)


def load_robot(
    source: str | Path = "demo",
    *,
    control: ControlMode | str | Mapping[str, ControlMode | str] = ControlMode.POSITION,
    scene: str | Path | None = None,
    packages: PackageMap | None = None,
    srdf: str | Path | None = None,
    visuals: bool = False,
    repair_inertia: bool = True,
    gains: Mapping[str, float] | None = None,
    cache_dir: str | Path | None = None,
    pose: PoseLike = None,
    initial_positions: Mapping[str, float] | None = None,
    robot_args: RobotArgs | None = None,
    strict: bool = False,
    self_collision: SelfCollision | None = None,
    base: BaseKind | None = None,
) -> LoadedRobot:
    """Load ``source`` into MuJoCo with one actuator per controllable joint.

    ``source``: ``"demo"`` (default scene ``"table"``), or a .urdf, .sdf/.world or MJCF
    (.xml/.mjcf, taken as is: its own actuators are kept, others are added only when it has
    none, and it gets a scene only when one is asked for). ``control``: one mode for every
    controllable joint or a mapping joint -> mode (unlisted joints: ``"position"``).
    ``scene``: None (a floor), ``"floor"``, ``"empty"``, ``"table"`` or an MJCF world file.
    ``packages``: package name -> folder for ``package://``. ``srdf``: its
    ``<disable_collisions>`` become body-pair excludes. ``visuals``: keep visual geoms
    (non-colliding). ``repair_inertia`` (default): bound masses/inertias and balance
    inertias, reporting every changed link in ``repairs`` and as a :class:`ModelWarning`.
    ``strict``: refuse what a lenient load would recover or repair (bad inertias, a wrong XML
    declaration, trailing content, equal joint limits, ...). ``self_collision``: ``"auto"``,
    ``"off"``, ``"on"`` or ``"srdf"`` (see :mod:`harness.models.selfcollision`). ``base``:
    ``"fixed"`` or ``"floating"`` (see :mod:`harness.models.placement`). ``gains``: joint ->
    kp (position) or kv (velocity) overriding the defaults. ``cache_dir``: converted-mesh
    cache folder.
    ``pose``: where the robot's base (model frame) is in the world (see
    :data:`harness.models.world.PoseLike`). ``initial_positions``: joint -> position
    overriding the ``home`` keyframe (created if the robot has none). ``robot_args``: the
    arguments of a xacro robot (name -> value, see :mod:`harness.models.xacro`); ``source``
    may also be ``package://pkg/path`` (found like a mesh's package).

    A URDF's ``<harness>`` element adds keyframes and joint armature (see
    :func:`harness.models.urdf.harness_extension`): the model depends on file contents only,
    never on where the file is. Position servos are critically damped (servo kv plus joint
    damping) for the inertia each joint sees with the others held, at the ``home`` keyframe;
    their joint gets the drive's torque-speed limit, effort / velocity, as extra damping, so a
    saturated servo moves at about its velocity limit and stops at its target.

    This is :func:`load_world` with one robot in the empty namespace: names stay unprefixed.
    """
    robot = RobotSpec(
        source,
        namespace="",
        pose=pose,
        control=control,
        gains=gains,
        packages=packages,
        srdf=srdf,
        visuals=visuals,
        repair_inertia=repair_inertia,
        initial_positions=dict(initial_positions or {}),
        robot_args=dict(robot_args or {}),
        strict=strict,
        self_collision=self_collision,
        base=base,
    )
    world = load_world([robot], scene=scene, cache_dir=cache_dir)
    view = world.robots[0]
    return LoadedRobot(
        name=view.description.name,
        description=view.description,
        spec=world.spec,
        model=world.model,
        control=view.control,
        actuated=view.actuated,
        kinematic=view.kinematic,
        mjcf=world.mjcf,
        mjb=world.mjb,
        sources=world.sources,
        sha256=world.sha256,
        repairs=view.repairs,
        notes=view.notes,
        self_collision=view.self_collision,
        base=view.base,
        placement=view.placement,
    )


def load_world(
    robots: Sequence[RobotSpec],
    *,
    scene: str | Path | None = None,
    objects: Sequence[WorldObject] = (),
    timestep: float | None = None,
    cache_dir: str | Path | None = None,
) -> LoadedWorld:
    """Load several robots (and primitive ``objects``) into one world and compile it.

    Each robot is built as :func:`load_robot` builds it and attached at its ``pose`` with
    the prefix ``"<namespace>/"`` on every name it brings (a namespace of None takes the
    robot's own name; ``""`` keeps names as they are). Robots are separate kinematic trees:
    their links can collide with each other (bases fixed to the world never do).
    ``scene``: as for :func:`load_robot`; None gives the ``"table"`` when the first robot is
    the demo, a lone MJCF robot in the empty namespace its own world, else ``"floor"``.
    ``objects`` are added to the world body before the robots (free objects come first in
    ``qpos``, after the scene's). ``timestep`` overrides the scene's (the servo gains are
    tuned for it).

    Keyframes combine: each key name any robot has becomes one key whose robot part is that
    robot's key of that name (else its ``home``, else its zero configuration), whose rest is
    the scene's key of that name (else the model's default), with position servo targets at
    their joint's position; ``initial_positions`` override a robot's part of ``home``.
    Keys keep qpos, qvel (of a robot's own MJCF keys), ctrl and time, not act or mocap.
    Errors: :class:`DuplicateNamespaceError`, :class:`InvalidNamespaceError` and the other
    :class:`ModelError` of :func:`load_robot`, naming ``robots[i]``.
    """
    if not robots:
        raise ModelStructureError("load_world: no robots given")
    several = len(robots) > 1
    prepared: list[_Robot] = []
    namespaces: dict[str, int] = {}
    for index, request in enumerate(robots):
        robot = _Robot(index, request, cache_dir)
        where = robot.where(several)
        if request.namespace is None:
            namespace = check_namespace(robot.description.name, where)
        else:
            namespace = check_namespace(request.namespace, where)
        if namespace in namespaces:
            raise DuplicateNamespaceError(
                f"{where}: namespace {namespace!r} is already robots[{namespaces[namespace]}]'s "
                "(give each robot its own namespace)"
            )
        namespaces[namespace] = index
        robot.set_namespace(namespace)
        prepared.append(robot)
    placements = [placement_pose(r.request.pose, r.where(several)) for r in prepared]
    first_robot = prepared[0]
    world_source = first_robot.source if not several else f"world [{', '.join(namespaces)}]"

    sources: dict[str, bytes] = {}
    for robot in prepared:
        sources[f"model/{robot.prefix}{robot.path.name}"] = robot.model_bytes
        sources.update(_prefixed(robot.extra_sources, robot.prefix))
    if scene is None and str(first_robot.request.source) == "demo":
        scene = "table"
    own_world = scene is None and not several and first_robot.kind == "mjcf"
    own_world = own_world and first_robot.namespace == ""
    if own_world:
        spec = first_robot.spec
        if placements[0] is not None:
            _place_top_bodies(spec, placements[0])
        for number, obj in enumerate(objects):
            _add_object(spec, obj, f"{world_source}: objects[{number}] ({obj.name!r})")
    else:
        spec, _scene_path, scene_sources = _scene_spec(scene, world_source, cache_dir)
        sources.update(scene_sources)
        for number, obj in enumerate(objects):
            _add_object(spec, obj, f"{world_source}: objects[{number}] ({obj.name!r})")
        for robot, placement in zip(prepared, placements, strict=True):
            if placement is None:
                frame = spec.worldbody.add_frame()
            else:
                frame = spec.worldbody.add_frame(pos=list(placement.xyz), quat=list(placement.quat))
            robot.frame = frame
            try:
                with _mujoco_warnings():
                    spec.attach(robot.spec, prefix=robot.prefix, frame=frame)
            except ValueError as exc:
                raise CompileError(
                    f"{robot.where(several)}: cannot attach the robot into the scene: "
                    f"{_mujoco_message(exc)}"
                ) from None
    if timestep is not None:
        if not (math.isfinite(timestep) and timestep > 0):
            raise ModelStructureError(f"{world_source}: timestep {timestep!r} is not positive")
        spec.option.timestep = timestep
    spec.modelname = first_robot.description.name if not several else "world"

    first = _compile_lenient(spec, world_source, prepared)
    joint_names = {first.joint(j).name for j in range(first.njnt)}
    servo_qpos = np.array(first.qpos0, dtype=float)
    for robot in prepared:
        setup.start_within_limits(first, robot)
        robot.key_values(first, "home", servo_qpos)
    held = _held_inertia(first, servo_qpos)
    for robot in prepared:
        where = robot.where(several)
        if robot.existing_actuators:
            robot.modes, robot.actuated = _existing_control(first, robot.prefix, robot.description)
            continue
        own_joints = {
            name.removeprefix(robot.prefix) for name in joint_names if name.startswith(robot.prefix)
        }
        robot.modes = _resolve_control(robot.description, own_joints, robot.request.control, where)
        robot.modes = control_defaults(robot.description, robot.modes, robot.request.control)
        robot.modes = plugin_modes(robot.modes, robot.plugin_wheels, robot.request.control)
        robot.modes = drop_passive(robot.modes, robot.declared_actuated, robot.request.control)
        gains = dict(robot.request.gains or {})
        unknown_gains = sorted(set(gains) - set(robot.modes))
        if unknown_gains:
            raise ModelStructureError(
                f"{where}: gains name joints that are not controllable: {unknown_gains}"
            )
        robot.actuated = _add_actuators(
            spec, first, robot.description, robot.modes, gains, held, robot.prefix
        )
        setup.compensate_gravity(spec, first, robot)
    for robot in prepared:
        if robot.request.srdf is not None:
            srdf = Path(robot.request.srdf)
            body_names = {first.body(b).name for b in range(first.nbody)}
            if robot.prefix:  # only this robot's links
                links = {link.name for link in robot.description.links}
                body_names = {n for n in links if robot.prefix + n in body_names}
            sources[f"srdf/{robot.prefix}{srdf.name}"], robot.srdf_pairs = _add_srdf_excludes(
                spec, srdf, body_names, robot.prefix
            )
    for index, robot in enumerate(prepared):
        setup.apply_self_collision(spec, first, robot, servo_qpos)
        if robot.frame is not None:
            placements[index] = setup.place_on_floor(first, robot, servo_qpos, placements[index])
    _combine_keyframes(spec, first, prepared, several)

    model = _compile(spec, world_source)
    for robot in prepared:
        if robot.repair:
            robot.repairs_made = robot.source_repairs + _repairs(
                model, robot.description, robot.repaired_inertias, robot.prefix
            )
    setup.report_start(model, prepared)
    with _mujoco_warnings():
        mjcf = spec.to_xml()
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    views = tuple(
        _view(model, robot, placement or Pose(), sources)
        for robot, placement in zip(prepared, placements, strict=True)
    )
    control: dict[str, ControlMode] = {}
    for view in views:
        control.update({view.mujoco_name(j): m for j, m in view.control.items()})
    actuated = tuple(
        model.joint(int(model.actuator_trnid[a][0])).name
        for a in range(model.nu)
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
    )
    return LoadedWorld(
        name=str(spec.modelname),
        spec=spec,
        model=model,
        robots=views,
        control=MappingProxyType(control),
        actuated=actuated,
        kinematic=tuple(n for n, m in control.items() if m == "kinematic"),
        mjcf=mjcf,
        mjb=buffer.tobytes(),
        sources=MappingProxyType(sources),
        sha256=hashlib.sha256(mjcf.encode()).hexdigest(),
    )


def _combine_keyframes(
    spec: mujoco.MjSpec, first: mujoco.MjModel, robots: Sequence[_Robot], several: bool
) -> None:
    """Replace the robots' own keys (and the scene's keys of the same names) with combined
    keys (see :func:`load_world`)."""
    names: list[str] = []
    for robot in robots:
        for name in (*robot.extension_keys, *robot.spec_keys):
            if name not in names:
                names.append(name)
    if "home" not in names and any(r.request.initial_positions for r in robots):
        names.append("home")
    if not names:
        return
    robot_keys = {r.prefix + k for r in robots for k in r.spec_keys}
    scene_keys = {
        first.key(k).name: k for k in range(first.nkey) if first.key(k).name not in robot_keys
    }
    added_actuators = [
        (robot, joint)
        for robot in robots
        if not robot.existing_actuators
        for joint in robot.actuated
    ]
    keys: list[dict[str, Any]] = []
    for name in names:
        scene_key = scene_keys.get(name, -1)
        qpos = np.array(first.qpos0 if scene_key < 0 else first.key_qpos[scene_key], dtype=float)
        qvel = np.zeros(first.nv) if scene_key < 0 else np.array(first.key_qvel[scene_key])
        ctrl = np.zeros(first.nu) if scene_key < 0 else np.array(first.key_ctrl[scene_key])
        act = np.zeros(first.na) if scene_key < 0 else np.array(first.key_act[scene_key])
        time = 0.0 if scene_key < 0 else float(first.key_time[scene_key])
        for robot in robots:
            own, _ = robot.key_values(first, name, qpos)
            joints = robot.joint_ids(first)
            if own >= 0:
                time = float(first.key_time[own])
                for j in joints:
                    start, width = _dof_span(first, j)
                    qvel[start : start + width] = first.key_qvel[own][start : start + width]
            if name == "home":
                _apply_initial_positions(first, robot, qpos, several)
            for a in range(first.nu):
                joint = int(first.actuator_trnid[a][0])
                if first.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT or joint not in joints:
                    continue
                if own >= 0:
                    ctrl[a] = first.key_ctrl[own][a]
                unprefixed = first.joint(joint).name.removeprefix(robot.prefix)
                overridden = name == "home" and unprefixed in robot.request.initial_positions
                if overridden and robot.modes.get(unprefixed) == "position":
                    ctrl[a] = qpos[first.jnt_qposadr[joint]]
        added = [
            float(qpos[first.jnt_qposadr[first.joint(robot.prefix + joint).id]])
            if robot.modes.get(joint) == "position"
            else 0.0
            for robot, joint in added_actuators
        ]
        # each added position servo's command filter starts at its command
        filtered = [
            value
            for value, (robot, joint) in zip(added, added_actuators, strict=True)
            if robot.modes.get(joint) == "position"
        ]
        keys.append(
            {
                "name": name,
                "time": time,
                "qpos": qpos.tolist(),
                "qvel": qvel.tolist(),
                "ctrl": [*ctrl.tolist(), *added],
                "act": [*act.tolist(), *filtered],
            }
        )
    for key in list(spec.keys):
        if key.name in robot_keys or key.name in names:
            spec.delete(key)
    for key_options in keys:
        spec.add_key(**key_options)


def _apply_initial_positions(
    model: mujoco.MjModel, robot: _Robot, qpos: npt.NDArray[np.float64], several: bool
) -> None:
    wanted = robot.request.initial_positions
    single_dof = {
        model.joint(j).name.removeprefix(robot.prefix): j
        for j in robot.joint_ids(model)
        if _qpos_span(model, j)[1] == 1
    }
    unknown = sorted(set(wanted) - set(single_dof))
    if unknown:
        raise ModelStructureError(
            f"{robot.where(several)}: initial_positions name no hinge or slide joint of the "
            f"robot: {unknown} (joints: {', '.join(sorted(single_dof))})"
        )
    for name, value in wanted.items():
        if not math.isfinite(value):
            raise ModelStructureError(
                f"{robot.where(several)}: initial_positions[{name!r}] = {value!r} is not finite"
            )
        qpos[model.jnt_qposadr[single_dof[name]]] = value


def _view(
    model: mujoco.MjModel, robot: _Robot, placement: Pose, sources: Mapping[str, bytes]
) -> LoadedRobotView:
    joints: dict[str, JointAddress] = {}
    for j in robot.joint_ids(model):
        name = model.joint(j).name
        start, width = _qpos_span(model, j)
        dof, dofs = _dof_span(model, j)
        joints[name.removeprefix(robot.prefix)] = JointAddress(name, j, start, dof, width, dofs)
    by_joint = {address.id: joint for joint, address in joints.items()}
    actuators = {
        by_joint[int(model.actuator_trnid[a][0])]: a
        for a in range(model.nu)
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
        and int(model.actuator_trnid[a][0]) in by_joint
    }
    bodies = {
        link.name: int(model.body(robot.prefix + link.name).id)
        for link in robot.description.links
        if _has_body(model, robot.prefix + link.name)
    }
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = model.key_qpos[key] if key >= 0 else model.qpos0
    home = {
        joint: float(qpos[address.qpos]) for joint, address in joints.items() if address.nq == 1
    }
    mine = {
        f"model/{robot.prefix}{robot.path.name}",
        f"srdf/{robot.prefix}{Path(robot.request.srdf).name}" if robot.request.srdf else "",
        *_prefixed(robot.extra_sources, robot.prefix),
    }
    return LoadedRobotView(
        namespace=robot.namespace,
        description=robot.description,
        placement=placement,
        control=MappingProxyType(dict(robot.modes)),
        actuated=robot.actuated,
        kinematic=tuple(n for n, m in robot.modes.items() if m == "kinematic"),
        joints=MappingProxyType(joints),
        actuators=MappingProxyType(actuators),
        bodies=MappingProxyType(bodies),
        home=MappingProxyType(home),
        sources=MappingProxyType({k: v for k, v in sources.items() if k in mine}),
        repairs=robot.repairs_made,
        notes=tuple(robot.notes),
        self_collision=robot.self_collision,
        base=robot.base,
    )


def _prefixed(sources: Mapping[str, bytes], prefix: str) -> dict[str, bytes]:
    """``"<role>/<rest>"`` -> ``"<role>/<prefix><rest>"`` (a robot's namespace in a world)."""
    out = {}
    for name, blob in sources.items():
        role, _, rest = name.partition("/")
        out[f"{role}/{prefix}{rest}"] = blob
    return out


def _existing_control(
    model: mujoco.MjModel, prefix: str, description: RobotModel
) -> tuple[dict[str, ControlMode], tuple[str, ...]]:
    """Control modes of an MJCF's own joint actuators, inferred from gain and bias (joint
    names unprefixed)."""
    own = {prefix + j.name for j in description.joints}
    modes: dict[str, ControlMode] = {}
    actuated = []
    for a in range(model.nu):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        joint = model.joint(int(model.actuator_trnid[a][0])).name
        if joint not in own:
            continue
        bias: Any = model.actuator_biasprm[a]
        mode = ControlMode.EFFORT
        if model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE:
            mode = ControlMode.POSITION if bias[1] != 0 else ControlMode.VELOCITY
        joint = joint.removeprefix(prefix)
        modes[joint] = mode
        actuated.append(joint)
    return modes, tuple(actuated)
