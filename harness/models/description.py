"""`RobotModel`: one description of a robot, independent of MuJoCo and of the source format.

URDF, SDF and MJCF loaders all produce it. Every pose is expressed in the **model frame at the
zero configuration** (metres, unit quaternions w-x-y-z), so checks and ``harness inspect-model``
can use it without running forward kinematics, and limits MuJoCo ignores (URDF velocity limits)
stay available.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from harness.vocabulary import CONTROL_MODE_INPUTS, CONTROL_MODES, DYNAMIC_ALIAS, ControlMode

if TYPE_CHECKING:
    from harness.models.urdf.ros2_control import Ros2Control

__all__ = [
    "CONTROL_MODES",
    "CONTROL_MODE_INPUTS",
    "DYNAMIC_ALIAS",
    "Appearance",
    "ControlMode",
    "Geometry",
    "Inertial",
    "Joint",
    "JointLimits",
    "JointType",
    "Link",
    "Mimic",
    "ModelFrame",
    "Pose",
    "RobotModel",
    "Shape",
    "XacroOrigin",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

JointType = Literal[
    "revolute", "continuous", "prismatic", "fixed", "floating", "planar", "ball", "screw"
]
GeometryKind = Literal["box", "cylinder", "sphere", "capsule", "ellipsoid", "plane", "mesh"]


def _quat_mul(a: Sequence[float], b: Sequence[float]) -> Quat:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@dataclass(frozen=True)
class Pose:
    """A rigid transform: translation ``xyz`` and rotation ``quat`` (w, x, y, z, unit norm).

    ``a * b`` composes (``b`` expressed in ``a``'s frame), so ``T_model_link =
    T_model_parent * T_parent_link``.
    """

    xyz: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = (1.0, 0.0, 0.0, 0.0)

    @staticmethod
    def identity() -> Pose:
        return Pose()

    @staticmethod
    def from_xyz_rpy(xyz: Sequence[float], rpy: Sequence[float]) -> Pose:
        """Fixed-axis roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), as URDF and SDF use."""
        r, p, y = (float(v) for v in rpy)
        cr, sr = math.cos(r / 2), math.sin(r / 2)
        cp, sp = math.cos(p / 2), math.sin(p / 2)
        cy, sy = math.cos(y / 2), math.sin(y / 2)
        quat = (
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        )
        return Pose((float(xyz[0]), float(xyz[1]), float(xyz[2])), quat).normalized()

    @staticmethod
    def from_matrix(matrix: npt.ArrayLike) -> Pose:
        """From a 4x4 homogeneous transform."""
        m = np.asarray(matrix, dtype=float)
        rot = m[:3, :3]
        trace = float(np.trace(rot))
        if trace > 0:
            s = math.sqrt(trace + 1.0) * 2
            q = (
                0.25 * s,
                (rot[2, 1] - rot[1, 2]) / s,
                (rot[0, 2] - rot[2, 0]) / s,
                (rot[1, 0] - rot[0, 1]) / s,
            )
        elif rot[0, 0] > rot[1, 1] and rot[0, 0] > rot[2, 2]:
            s = math.sqrt(1.0 + rot[0, 0] - rot[1, 1] - rot[2, 2]) * 2
            q = (
                (rot[2, 1] - rot[1, 2]) / s,
                0.25 * s,
                (rot[0, 1] + rot[1, 0]) / s,
                (rot[0, 2] + rot[2, 0]) / s,
            )
        elif rot[1, 1] > rot[2, 2]:
            s = math.sqrt(1.0 + rot[1, 1] - rot[0, 0] - rot[2, 2]) * 2
            q = (
                (rot[0, 2] - rot[2, 0]) / s,
                (rot[0, 1] + rot[1, 0]) / s,
                0.25 * s,
                (rot[1, 2] + rot[2, 1]) / s,
            )
        else:
            s = math.sqrt(1.0 + rot[2, 2] - rot[0, 0] - rot[1, 1]) * 2
            q = (
                (rot[1, 0] - rot[0, 1]) / s,
                (rot[0, 2] + rot[2, 0]) / s,
                (rot[1, 2] + rot[2, 1]) / s,
                0.25 * s,
            )
        xyz = (float(m[0, 3]), float(m[1, 3]), float(m[2, 3]))
        return Pose(xyz, (float(q[0]), float(q[1]), float(q[2]), float(q[3]))).normalized()

    def normalized(self) -> Pose:
        n = math.sqrt(sum(c * c for c in self.quat))
        if n == 0.0:
            raise ValueError("zero quaternion")
        w, x, y, z = (c / n for c in self.quat)
        return Pose(self.xyz, (w, x, y, z))

    def rotation_matrix(self) -> npt.NDArray[np.float64]:
        w, x, y, z = self.quat
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )

    def matrix(self) -> npt.NDArray[np.float64]:
        """The 4x4 homogeneous transform."""
        m = np.eye(4)
        m[:3, :3] = self.rotation_matrix()
        m[:3, 3] = self.xyz
        return m

    def rotate(self, vector: Sequence[float]) -> Vec3:
        v = self.rotation_matrix() @ np.asarray(vector, dtype=float)
        return (float(v[0]), float(v[1]), float(v[2]))

    def transform_point(self, point: Sequence[float]) -> Vec3:
        x, y, z = self.rotate(point)
        return (x + self.xyz[0], y + self.xyz[1], z + self.xyz[2])

    def inverse(self) -> Pose:
        w, x, y, z = self.quat
        conj = (w, -x, -y, -z)
        inv_rot = Pose((0.0, 0.0, 0.0), conj)
        tx, ty, tz = inv_rot.rotate(self.xyz)
        return Pose((-tx, -ty, -tz), conj)

    def __mul__(self, other: Pose) -> Pose:
        tx, ty, tz = self.transform_point(other.xyz)
        return Pose((tx, ty, tz), _quat_mul(self.quat, other.quat)).normalized()

    def rpy(self) -> Vec3:
        """Fixed-axis roll, pitch, yaw of the rotation."""
        w, x, y, z = self.quat
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        sinp = max(-1.0, min(1.0, 2 * (w * y - z * x)))
        pitch = math.asin(sinp)
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return (roll, pitch, yaw)

    def as_list(self) -> list[float]:
        """``[x, y, z, qw, qx, qy, qz]``: the pose encoding of ``inspect-model --json``."""
        return [*self.xyz, *self.quat]

    def is_close(self, other: Pose, atol: float = 1e-9) -> bool:
        """Equal translation and rotation within ``atol`` (quaternions compared up to sign)."""
        dt = max(abs(a - b) for a, b in zip(self.xyz, other.xyz, strict=True))
        dot = abs(sum(a * b for a, b in zip(self.quat, other.quat, strict=True)))
        return dt <= atol and 1.0 - min(1.0, dot) <= atol


@dataclass(frozen=True)
class Geometry:
    """A geometric primitive or mesh.

    ``size`` by kind: box (x, y, z full lengths), cylinder and capsule (radius, length),
    sphere (radius,), ellipsoid (rx, ry, rz), plane (x, y) or (), mesh ().
    """

    kind: GeometryKind
    size: tuple[float, ...] = ()
    mesh_path: str | None = None
    mesh_scale: Vec3 = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Appearance:
    """How a visual is drawn (its material), in MuJoCo's terms: ``rgba`` the colour the lights
    and the ambient light scale (Gazebo's diffuse), ``emission`` the part of it drawn unlit,
    ``specular`` and ``shininess`` (0-1), ``texture`` an image file (PNG) multiplied with
    ``rgba``; ``source``: where it was read (for messages)."""

    rgba: tuple[float, float, float, float]
    emission: float = 0.0
    specular: float = 0.5
    shininess: float = 0.5
    texture: str | None = None
    source: str = ""


@dataclass(frozen=True)
class Shape:
    """A collision or visual element of a link; ``pose`` is in the model frame at zero config;
    ``appearance``: a visual's material, when its file gives one (not part of equality: it
    changes no geometry)."""

    name: str
    pose: Pose
    geometry: Geometry
    appearance: Appearance | None = field(default=None, compare=False)


@dataclass(frozen=True)
class Inertial:
    """Mass, centre-of-mass frame (model frame at zero config) and inertia about it, in that
    frame's axes: (ixx, ixy, ixz, iyy, iyz, izz)."""

    mass: float
    pose: Pose
    inertia: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class Link:
    """A rigid body. ``pose``: the link frame in the model frame at the zero configuration."""

    name: str
    pose: Pose
    inertial: Inertial | None = None
    collisions: tuple[Shape, ...] = ()
    visuals: tuple[Shape, ...] = ()


@dataclass(frozen=True)
class JointLimits:
    """Limits as written in the source; ``None`` where the source gives none."""

    lower: float | None = None
    upper: float | None = None
    velocity: float | None = None
    effort: float | None = None


@dataclass(frozen=True)
class Mimic:
    """``q = multiplier * q[joint] + offset``."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Joint:
    """A joint. ``pose``: the joint frame in the model frame at zero config; ``axis``: a unit
    vector in the model frame (``(0, 0, 0)`` for joints without an axis)."""

    name: str
    type: JointType
    parent: str
    child: str
    pose: Pose
    axis: Vec3 = (0.0, 0.0, 0.0)
    limits: JointLimits = field(default_factory=JointLimits)
    mimic: Mimic | None = None
    damping: float = 0.0
    friction: float = 0.0

    @property
    def is_controllable(self) -> bool:
        """One actuated degree of freedom: hinge or slide and not a mimic follower."""
        return self.type in ("revolute", "continuous", "prismatic") and self.mimic is None


@dataclass(frozen=True)
class ModelFrame:
    """A named frame (SDF ``<frame>``); ``attached_to`` is the link or frame it moves with."""

    name: str
    attached_to: str
    pose: Pose


@dataclass(frozen=True)
class XacroOrigin:
    """Where an expanded description came from: ``source`` (the entry file as the user named
    it: a path or ``package://pkg/...``), the ``args`` it was expanded with and the keys of
    the source files it read (see :attr:`Expansion.sources`)."""

    source: str
    args: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    files: tuple[str, ...] = ()


@dataclass(frozen=True)
class RobotModel:
    """A robot description in the model frame at the zero configuration.

    ``ros2_control``: the URDF's ``<ros2_control>`` blocks
    (:mod:`harness.models.urdf.ros2_control`);
    ``xacro``: where an expanded xacro description came from (entry file and arguments)."""

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...] = ()
    frames: tuple[ModelFrame, ...] = ()
    source: str | None = None
    format: Literal["urdf", "sdf", "mjcf"] = "urdf"
    ros2_control: Ros2Control | None = None
    xacro: XacroOrigin | None = None

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(f"robot {self.name!r} has no link {name!r}")

    def joint(self, name: str) -> Joint:
        joint = self._joints_by_name.get(name)
        if joint is None:
            raise KeyError(f"robot {self.name!r} has no joint {name!r}")
        return joint

    @functools.cached_property
    def _joints_by_name(self) -> dict[str, Joint]:
        # One lookup per joint while building made loading quadratic in the joint count.
        found: dict[str, Joint] = {}
        for joint in self.joints:
            found.setdefault(joint.name, joint)
        return found

    @property
    def root_link(self) -> str | None:
        """The first link that is no other link's child (the body a floating base moves),
        or None."""
        link_names = {link.name for link in self.links}
        children = {joint.child for joint in self.joints if joint.parent in link_names}
        roots = [link.name for link in self.links if link.name not in children]
        return roots[0] if roots else None

    @property
    def controllable_joints(self) -> tuple[Joint, ...]:
        """Joints that get an actuator, in declaration order."""
        return tuple(j for j in self.joints if j.is_controllable)

    def joint_names(self, joints: Iterable[Joint] | None = None) -> list[str]:
        return [j.name for j in (self.joints if joints is None else joints)]
