"""Records of a world with several robots: what to load (:class:`RobotSpec`, :class:`WorldObject`)
and what was loaded (:class:`LoadedWorld`, one :class:`LoadedRobotView` per robot).

Each robot is attached into the world with the prefix ``"<namespace>/"`` on every MuJoCo name
it brings (bodies, joints, geoms, sites, actuators, equalities, meshes, materials); a robot
with the empty namespace keeps its names (the one-robot :func:`harness.models.load_robot`).
A view maps the robot's own (unprefixed) names to the compiled model's names, ids and
addresses; its :class:`RobotModel` keeps unprefixed names and model-frame poses, and
``placement`` is the model frame's pose in the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Literal, NamedTuple, cast

import mujoco

from harness import vocabulary
from harness.models.description import ControlMode, Joint, Link, ModelFrame, Pose, RobotModel
from harness.models.errors import ModelStructureError
from harness.models.files.resolve import PackageMap
from harness.models.xacro.expand import RobotArgs
from harness.names import name_problem

__all__ = [
    "BASE_KINDS",
    "OBJECT_SIZES",
    "SELF_COLLISION_POLICIES",
    "BaseKind",
    "DuplicateNamespaceError",
    "IgnoredPair",
    "InvalidNamespaceError",
    "JointAddress",
    "LoadedRobotView",
    "LoadedWorld",
    "ObjectShape",
    "PoseLike",
    "RobotSpec",
    "SelfCollision",
    "SelfCollisionReport",
    "WorldObject",
    "add_object",
    "check_namespace",
    "object_friction",
    "placement_pose",
    "set_object_values",
]

PoseLike = Pose | Sequence[float] | None
"""A placement: a :class:`Pose`, ``[x, y, z, qw, qx, qy, qz]``, ``[x, y, z, roll, pitch, yaw]``
(fixed axes, radians, as URDF), ``[x, y, z]`` or None (the world origin)."""

ObjectShape = Literal["box", "sphere", "cylinder", "capsule"]
SelfCollision = Literal["auto", "off", "on", "srdf"]
"""Self-collision policies (see :mod:`harness.models.build.selfcollision`)."""
SELF_COLLISION_POLICIES: tuple[SelfCollision, ...] = cast(
    "tuple[SelfCollision, ...]", vocabulary.SELF_COLLISION_POLICIES
)
"""The spellings of :class:`harness.vocabulary.SelfCollisionPolicy` (its members are accepted
too: they compare equal to their strings)."""
BaseKind = Literal["fixed", "floating"]
BASE_KINDS: tuple[BaseKind, ...] = cast("tuple[BaseKind, ...]", vocabulary.BASE_KINDS)
"""The spellings of :class:`harness.vocabulary.RobotBase`."""

OBJECT_SIZES: Mapping[str, int] = MappingProxyType(
    {"box": 3, "sphere": 1, "cylinder": 2, "capsule": 2}
)
"""How many numbers ``WorldObject.size`` has for each :data:`ObjectShape`."""
_GEOM_TYPES: Mapping[str, mujoco.mjtGeom] = MappingProxyType(
    {
        "box": mujoco.mjtGeom.mjGEOM_BOX,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
        "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
        "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    }
)


class InvalidNamespaceError(ModelStructureError):
    """A robot namespace is not one ROS name segment (see :mod:`harness.names`)."""


class DuplicateNamespaceError(ModelStructureError):
    """Two robots of one world have the same namespace."""


def check_namespace(namespace: str, where: str) -> str:
    """``namespace`` if it is empty or a valid ROS name segment (:mod:`harness.names`), else
    :class:`InvalidNamespaceError` naming ``where``."""
    problem = name_problem(namespace, "segment") if namespace else None
    if problem is not None:
        raise InvalidNamespaceError(
            f"{where}: namespace {namespace!r} is not a ROS name segment: it {problem}"
        )
    return namespace


def placement_pose(pose: PoseLike, where: str) -> Pose | None:
    """The :class:`Pose` of a :data:`PoseLike` (None stays None: no placement given)."""
    if pose is None or isinstance(pose, Pose):
        return pose
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise ModelStructureError(
            f"{where}: pose {pose!r} is not a Pose or a list of numbers"
        ) from None
    if not all(math.isfinite(v) for v in values):
        raise ModelStructureError(f"{where}: pose {values} has a non-finite value")
    if len(values) == 3:
        return Pose((values[0], values[1], values[2]))
    if len(values) == 6:
        return Pose.from_xyz_rpy(values[:3], values[3:])
    if len(values) == 7:
        if all(v == 0.0 for v in values[3:]):
            raise ModelStructureError(f"{where}: pose {values} has a zero quaternion")
        return Pose((values[0], values[1], values[2]), (*values[3:],)).normalized()  # type: ignore[arg-type]
    raise ModelStructureError(
        f"{where}: pose has {len(values)} numbers (expected 3: xyz, 6: xyz + roll pitch yaw, "
        "or 7: xyz + quaternion w x y z)"
    )


@dataclass(frozen=True)
class RobotSpec:
    """One robot to load into a world.

    ``source``: ``"demo"``, a .urdf, .sdf/.world or MJCF file. ``namespace``: the robot's name
    prefix (``"<namespace>/"`` on every MuJoCo name; later its ROS namespace); None takes the
    robot's own name, ``""`` keeps names unprefixed (at most one robot). ``pose``: where the
    robot's model frame is in the world (see :data:`PoseLike`). ``control``, ``gains``,
    ``packages``, ``srdf``, ``visuals``, ``repair_inertia``: as for
    :func:`harness.models.load_robot`, with the robot's unprefixed joint and link names.
    ``initial_positions``: joint -> position overriding the robot's ``home`` keyframe (the
    servos stay tuned at the source's own ``home``). ``robot_args``: a xacro robot's
    arguments (name -> value). ``strict``: refuse what a lenient load
    recovers or repairs (see :mod:`harness.models.urdf.lenient`; implies no inertia repair).
    ``self_collision``: which pairs of the robot's own links collide (see
    :mod:`harness.models.build.selfcollision`; None: the file's ``self_collide``, else the SRDF
    when given, else ``"auto"``). ``base``: ``"fixed"`` or ``"floating"`` (None: floating
    only for an SDF model that is not static, as before).
    """

    source: str | Path = "demo"
    namespace: str | None = None
    pose: PoseLike = None
    control: ControlMode | str | Mapping[str, ControlMode | str] = ControlMode.POSITION
    gains: Mapping[str, float] | None = None
    packages: PackageMap | None = None
    srdf: str | Path | None = None
    visuals: bool = False
    repair_inertia: bool = True
    initial_positions: Mapping[str, float] = field(default_factory=dict)
    robot_args: RobotArgs = field(default_factory=dict)
    strict: bool = False
    self_collision: SelfCollision | None = None
    base: BaseKind | None = None


@dataclass(frozen=True)
class WorldObject:
    """A primitive added to the world body: fixed, or free (with a free joint
    ``"<name>_joint"``) when it has a ``mass``. ``size``: box half extents (3), sphere radius
    (1), cylinder and capsule radius and half length (2), as MuJoCo sizes. ``friction``: the
    geom's sliding, torsional and rolling friction (1 to 3 values; the ones left out take
    MuJoCo's defaults, 0.005 and 0.0001; None: the scene's default geom friction)."""

    name: str
    shape: ObjectShape
    size: tuple[float, ...]
    pose: PoseLike = None
    mass: float | None = None
    rgba: tuple[float, float, float, float] | None = None
    friction: tuple[float, ...] | None = None

    def check(self, where: str) -> None:
        """Raise :class:`ModelStructureError` naming ``where`` when the object is malformed."""
        if not self.name or "/" in self.name:
            raise ModelStructureError(f"{where}: object name {self.name!r} is empty or has '/'")
        expected = OBJECT_SIZES.get(self.shape)
        if expected is None:
            raise ModelStructureError(
                f"{where}: unknown shape {self.shape!r} (expected one of {', '.join(OBJECT_SIZES)})"
            )
        if len(self.size) != expected or not all(math.isfinite(s) and s > 0 for s in self.size):
            raise ModelStructureError(
                f"{where}: a {self.shape} needs {expected} positive sizes, got {list(self.size)}"
            )
        if self.mass is not None and not (math.isfinite(self.mass) and self.mass > 0):
            raise ModelStructureError(f"{where}: mass {self.mass!r} is not positive")
        friction = self.friction
        if friction is not None and not (
            1 <= len(friction) <= 3 and all(math.isfinite(f) and f >= 0 for f in friction)
        ):
            raise ModelStructureError(
                f"{where}: friction {list(friction)} must be 1 to 3 numbers >= 0 (sliding, "
                "torsional, rolling)"
            )


def add_object(spec: mujoco.MjSpec, obj: WorldObject, where: str) -> None:
    """Add ``obj`` (checked: :meth:`WorldObject.check` naming ``where``) to ``spec``'s world
    body: a body and a geom both named ``obj.name``, and a free joint ``"<name>_joint"`` when
    it has a mass."""
    obj.check(where)
    body = spec.worldbody.add_body(name=obj.name)
    if obj.mass is not None:
        body.add_freejoint(name=f"{obj.name}_joint")
    geom = body.add_geom(name=obj.name, type=_GEOM_TYPES[obj.shape])
    set_object_values(body, geom, obj, placement_pose(obj.pose, where) or Pose())
    if obj.rgba is not None:
        geom.rgba = list(obj.rgba)


def set_object_values(
    body: mujoco.MjsBody,
    geom: mujoco.MjsGeom,
    obj: WorldObject,
    pose: Pose,
    number: Callable[[float], float] = float,
) -> None:
    """Put ``obj``'s values on its body and geom: ``pose``, size, mass, friction, each number
    through ``number`` (a warm world of ``harness explore`` rounds them as a scene file
    writes them)."""
    body.pos = [number(v) for v in pose.xyz]
    body.quat = [number(v) for v in pose.quat]
    geom.size = [number(v) for v in (*obj.size, *([0.0] * (3 - len(obj.size))))]
    if obj.mass is not None:
        geom.mass = number(obj.mass)
    if obj.friction is not None:
        geom.friction = [number(v) for v in object_friction(obj.friction)]


def object_friction(friction: Sequence[float]) -> list[float]:
    """An object's ``friction`` as MuJoCo's three values (MuJoCo's defaults for those left
    out: torsional 0.005, rolling 0.0001)."""
    full = [1.0, 0.005, 0.0001]
    full[: len(friction)] = [float(f) for f in friction]
    return full


class IgnoredPair(NamedTuple):
    """A pair of links whose collisions are ignored, and why: ``"adjacent"``, ``"default"``
    (in contact at the initial configuration), ``"always"`` (in contact in nearly every
    random configuration), ``"srdf"``, ``"off"`` (policy)."""

    link1: str
    link2: str
    reason: str


@dataclass(frozen=True)
class SelfCollisionReport:
    """The self-collision policy applied to one robot: ``policy``, where it came from
    (``origin``: ``"argument"``, ``"file"`` for a ``self_collide`` element, ``"srdf"``,
    ``"default"``) and the ignored pairs (unprefixed link names)."""

    policy: SelfCollision
    origin: str
    ignored: tuple[IgnoredPair, ...] = ()

    def as_dict(self) -> dict[str, object]:
        """A JSON-ready summary (for recording metadata and ``check-model --json``)."""
        return {
            "policy": self.policy,
            "origin": self.origin,
            "ignored": [[p.link1, p.link2, p.reason] for p in self.ignored],
        }


class JointAddress(NamedTuple):
    """Where a robot joint is in the compiled model: its MuJoCo ``name`` and ``id``, first
    ``qpos`` and ``qvel`` (dof) addresses and their counts ``nq`` and ``nv``."""

    name: str
    id: int
    qpos: int
    qvel: int
    nq: int
    nv: int


@dataclass(frozen=True)
class LoadedRobotView:
    """One robot of a :class:`LoadedWorld`, in its own names.

    ``description`` has the robot's unprefixed names and model-frame poses; ``placement`` is
    the model frame in the world. ``control`` (joint -> mode), ``actuated`` (this robot's
    actuated joints in actuator order) and ``kinematic`` use unprefixed joint names.
    ``joints`` (joint -> :class:`JointAddress`), ``actuators`` (joint -> actuator id) and
    ``bodies`` (link -> body id) map them into the compiled model. ``home`` holds the
    combined ``home`` keyframe's position of each 1-dof joint. ``sources`` are this robot's
    entries of the world's sources; ``repairs`` as :attr:`harness.models.LoadedRobot.repairs`;
    ``notes`` what a lenient load recovered and how the robot was placed; ``self_collision``
    the policy applied and the link pairs it ignores; ``base`` fixed or floating.
    """

    namespace: str
    description: RobotModel
    placement: Pose
    control: Mapping[str, ControlMode]
    actuated: tuple[str, ...]
    kinematic: tuple[str, ...]
    joints: Mapping[str, JointAddress]
    actuators: Mapping[str, int]
    bodies: Mapping[str, int]
    home: Mapping[str, float]
    sources: Mapping[str, bytes]
    repairs: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    self_collision: SelfCollisionReport | None = None
    base: BaseKind = "fixed"

    @property
    def prefix(self) -> str:
        """``"<namespace>/"``, or ``""`` for the empty namespace."""
        return f"{self.namespace}/" if self.namespace else ""

    def mujoco_name(self, name: str) -> str:
        """The MuJoCo name of this robot's element ``name`` (the prefix added)."""
        return self.prefix + name


@dataclass(frozen=True)
class LoadedWorld:
    """Robots and objects compiled into one MuJoCo model.

    ``control`` (MuJoCo joint name -> mode, every robot), ``actuated`` (the MuJoCo joint driven
    by each joint actuator, in actuator order, like :attr:`harness.models.LoadedRobot.actuated`)
    and ``kinematic``
    use prefixed names: ``Simulation.from_model(world.model, control=world.control)`` runs it.
    ``mjcf`` is for humans (6 significant digits), ``mjb`` the exact binary model, ``sha256``
    of ``mjcf``. ``sources`` maps ``"<role>/[<namespace>/]<file name>"`` (roles: model, srdf,
    scene) to bytes. ``robots`` in the order given. ``spec`` carries the mesh and texture files
    in ``spec.assets`` under content-derived names (see :mod:`harness.models.files.assets`), so
    ``mjb`` and ``mjcf`` do not depend on where the files are installed.
    """

    name: str
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    robots: tuple[LoadedRobotView, ...]
    control: Mapping[str, ControlMode]
    actuated: tuple[str, ...]
    kinematic: tuple[str, ...]
    mjcf: str
    mjb: bytes
    sources: Mapping[str, bytes]
    sha256: str
    mesh_collision: str = "decompose"
    """How non-convex collision meshes collide (:mod:`harness.models.build.decompose`); the cached
    pieces used are among ``sources`` (role ``decomposition``)."""

    def combined_description(self) -> RobotModel:
        """One :class:`RobotModel` of every robot: MuJoCo (prefixed) names, poses and axes in
        the world frame at the zero configuration (for code that takes one description, e.g.
        ``Simulation.from_model(..., description=...)`` for URDF velocity limits).

        Made once per world: it depends only on ``name`` and ``robots`` (frozen records of
        frozen descriptions), and the simulation, the loggers and the traces each ask; a copy
        made with :func:`dataclasses.replace` makes its own."""
        made = self.__dict__.get("_combined")
        if made is None:
            made = self._combine()
            object.__setattr__(self, "_combined", made)  # a cache, not a field
        return cast(RobotModel, made)

    def _combine(self) -> RobotModel:
        links: list[Link] = []
        joints: list[Joint] = []
        frames: list[ModelFrame] = []
        for view in self.robots:
            place, name = view.placement, view.mujoco_name
            for link in view.description.links:
                inertial = link.inertial
                links.append(
                    replace(
                        link,
                        name=name(link.name),
                        pose=place * link.pose,
                        inertial=None
                        if inertial is None
                        else replace(inertial, pose=place * inertial.pose),
                        collisions=tuple(replace(s, pose=place * s.pose) for s in link.collisions),
                        visuals=tuple(replace(s, pose=place * s.pose) for s in link.visuals),
                    )
                )
            for joint in view.description.joints:
                mimic = joint.mimic
                joints.append(
                    replace(
                        joint,
                        name=name(joint.name),
                        parent=name(joint.parent),
                        child=name(joint.child),
                        pose=place * joint.pose,
                        axis=place.rotate(joint.axis),
                        mimic=None if mimic is None else replace(mimic, joint=name(mimic.joint)),
                    )
                )
            for frame in view.description.frames:
                frames.append(
                    replace(
                        frame,
                        name=name(frame.name),
                        attached_to=name(frame.attached_to),
                        pose=place * frame.pose,
                    )
                )
        return RobotModel(
            self.name,
            tuple(links),
            tuple(joints),
            tuple(frames),
            format=self.robots[0].description.format,
        )

    def robot(self, namespace: str) -> LoadedRobotView:
        """The robot with ``namespace`` (:class:`KeyError` naming the namespaces if none)."""
        for view in self.robots:
            if view.namespace == namespace:
                return view
        raise KeyError(
            f"no robot with namespace {namespace!r} (robots: "
            f"{', '.join(repr(v.namespace) for v in self.robots)})"
        )
