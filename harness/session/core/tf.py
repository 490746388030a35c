"""The robots' transform tree as ``robot_state_publisher`` publishes it: one transform per
link from its parent link (the description's joint parent → child, not a flat tree under
``world``), the root links from ``world``. Transforms that cannot change go on the latched
``/tf_static`` once (fixed joints, sensor mounts, a base fixed to the world); the others on
``/tf`` at its rate (moving joints, floating bases, mocap bodies).

A transform is moving when anything between the parent's and the child's MuJoCo bodies can
move: a joint of a body on the path, or a mocap body. Poses come from the simulation's own
kinematics (a link moved by one joint from its parent: the joint's position and the body's
offset, the terms MuJoCo composes), so the tree composes to the world poses the simulation has
(to rounding).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from math import cos, sin
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models import RobotModel
from harness.recording import TfRecord
from harness.session.core.topics import stamp

__all__ = ["WORLD_FRAME", "RobotFrames", "TfEdge", "TfTree", "relative_pose"]

F64 = npt.NDArray[np.float64]
Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]

WORLD_FRAME = "world"
"""The frame id of the simulation's world (the parent of every root link)."""


@dataclass(frozen=True)
class RobotFrames:
    """One robot as the tree needs it: its ``description`` (unprefixed names), the ``prefix``
    of its MuJoCo body names and the ``frame_prefix`` of its frame ids (``<namespace>/``)."""

    description: RobotModel
    prefix: str = ""
    frame_prefix: str = ""


@dataclass(frozen=True)
class TfEdge:
    """One transform: ``parent``/``child`` frame ids, the MuJoCo bodies they are (``None``
    for the world) and whether it can change."""

    parent: str
    child: str
    parent_body: str | None
    child_body: str
    moving: bool


class TfTree:
    """The edges of every robot's tree in ``model`` (link order of each description)."""

    def __init__(self, model: mujoco.MjModel, robots: Iterable[RobotFrames]) -> None:
        edges: list[TfEdge] = []
        for robot in robots:
            parent_of = {j.child: j.parent for j in robot.description.joints}
            for link in robot.description.links:
                body = robot.prefix + link.name
                bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
                # a URDF link named "world" is MuJoCo's world body (id 0): the root frame itself
                if bid <= 0:
                    continue
                parent = parent_of.get(link.name)
                pid = (
                    -1
                    if parent is None
                    else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot.prefix + parent)
                )
                if parent is None or pid < 0:
                    edge = TfEdge(
                        WORLD_FRAME,
                        robot.frame_prefix + link.name,
                        None,
                        body,
                        _can_move(model, bid, 0),
                    )
                else:
                    edge = TfEdge(
                        robot.frame_prefix + parent,
                        robot.frame_prefix + link.name,
                        robot.prefix + parent if pid > 0 else None,
                        body,
                        _can_move(model, bid, pid),
                    )
                edges.append(edge)
        self.edges = tuple(edges)
        self.static = tuple(e for e in edges if not e.moving)
        """The transforms of ``/tf_static``."""
        self.moving = tuple(e for e in edges if e.moving)
        """The transforms of ``/tf``."""
        self._moving_pairs = tuple((e.parent, e.child) for e in self.moving)
        body = mujoco.mjtObj.mjOBJ_BODY
        # (parent, child) body ids of the moving edges; the world (id 0) has the identity pose
        ids = [
            (
                0 if e.parent_body is None else mujoco.mj_name2id(model, body, e.parent_body),
                mujoco.mj_name2id(model, body, e.child_body),
            )
            for e in self.moving
        ]
        self._hinges: list[tuple[int, int, float, Vec, Quat, Quat]] = []
        self._slides: list[tuple[int, int, float, Vec, Vec, Quat]] = []
        self._others: list[tuple[int, int, int]] = []
        for i, (p, c) in enumerate(ids):
            _plan(model, i, p, c, self._hinges, self._slides, self._others)

    def relative_poses(
        self, edges: tuple[TfEdge, ...], poses: Mapping[str, tuple[F64, F64]]
    ) -> list[tuple[Vec, Quat]]:
        """Each edge's child pose in its parent's frame, ``((x, y, z), (w, x, y, z))``, from
        the bodies' world ``poses`` (:meth:`harness.sim.Simulation.link_poses`)."""
        # plain floats: for a few transforms numpy's per-call cost dominates
        flat: dict[str | None, list[float]] = {None: [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]}
        for e in edges:
            for body in (e.parent_body, e.child_body):
                if body is not None and body not in flat:
                    xyz, quat = poses[body]
                    flat[body] = xyz.tolist() + quat.tolist()
        out = []
        for e in edges:
            p, c = flat[e.parent_body], flat[e.child_body]
            out.append(relative_pose(p[:3], p[3:], c[:3], c[3:]))
        return out

    def moving_poses(
        self, qpos: F64, body_poses: Callable[[], tuple[F64, F64]]
    ) -> list[tuple[Vec, Quat]]:
        """:meth:`relative_poses` of :attr:`moving` in the state whose positions are ``qpos``.

        A child moved by one hinge (at its origin) or slide joint from its parent body is
        posed from the joint's position alone, as MuJoCo's kinematics pose it (the body's
        offset, then the joint's rotation or translation); the others from every body's world
        pose (``body_poses``: :meth:`harness.sim.Simulation.body_poses`), called only then."""
        out: list[tuple[Vec, Quat]] = [((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))] * len(self.moving)
        q = qpos.tolist()
        for i, adr, q0, xyz, (aw, ax, ay, az), (bw, bx, by, bz) in self._hinges:
            # the body's quaternion times the joint's (cos h, sin h axis), h half the angle
            half = 0.5 * (q[adr] - q0)
            c, s = cos(half), sin(half)
            out[i] = xyz, (c * aw + s * bw, c * ax + s * bx, c * ay + s * by, c * az + s * bz)
        for i, adr, q0, (x, y, z), (ux, uy, uz), quat in self._slides:
            d = q[adr] - q0
            out[i] = (x + d * ux, y + d * uy, z + d * uz), quat
        if self._others:
            xpos, xquat = body_poses()
            positions, quats = xpos.tolist(), xquat.tolist()
            for i, p, c in self._others:
                out[i] = relative_pose(positions[p], quats[p], positions[c], quats[c])
        return out

    def message(
        self, edges: tuple[TfEdge, ...], poses: Mapping[str, tuple[F64, F64]], sim_time_ns: int
    ) -> dict[str, Any]:
        """The ``tf2_msgs/msg/TFMessage`` of ``edges`` from the bodies' world ``poses``
        (:meth:`harness.sim.Simulation.link_poses`)."""
        return self.transforms(edges, self.relative_poses(edges, poses), sim_time_ns)

    def transforms(
        self, edges: tuple[TfEdge, ...], relative: list[tuple[Vec, Quat]], sim_time_ns: int
    ) -> dict[str, Any]:
        """The ``tf2_msgs/msg/TFMessage`` of ``edges`` from their ``relative`` poses
        (:meth:`relative_poses`, :meth:`moving_poses`)."""
        time = stamp(sim_time_ns)
        transforms = []
        for e, ((x, y, z), (w, rx, ry, rz)) in zip(edges, relative, strict=True):
            transforms.append(
                {
                    "header": {"stamp": time, "frame_id": e.parent},
                    "child_frame_id": e.child,
                    "transform": {
                        "translation": {"x": x, "y": y, "z": z},
                        "rotation": {"x": rx, "y": ry, "z": rz, "w": w},
                    },
                }
            )
        return {"transforms": transforms}

    def moving_message(
        self, relative: Callable[[], list[tuple[Vec, Quat]]], sim_time_ns: int
    ) -> dict[str, Any]:
        """:meth:`transforms` of :attr:`moving` from ``relative()`` (:meth:`moving_poses`)."""
        return self.transforms(self.moving, relative(), sim_time_ns)

    def moving_record(
        self, relative: Callable[[], list[tuple[Vec, Quat]]], sim_time_ns: int
    ) -> TfRecord:
        """:meth:`moving_message` as the recording's record of it (``/tf``)."""
        return TfRecord(sim_time_ns, self._moving_pairs, relative())


def _plan(
    model: mujoco.MjModel,
    i: int,
    parent: int,
    child: int,
    hinges: list[tuple[int, int, float, Vec, Quat, Quat]],
    slides: list[tuple[int, int, float, Vec, Vec, Quat]],
    others: list[tuple[int, int, int]],
) -> None:
    """How moving edge ``i`` is posed: from its one hinge or slide joint when the child's
    MuJoCo parent is the edge's parent, else from world poses."""
    joint = int(model.body_jntadr[child])
    kind = int(model.jnt_type[joint]) if model.body_jntnum[child] == 1 else -1
    local = (
        int(model.body_parentid[child]) == parent  # the world (0) included
        and model.body_mocapid[child] < 0
        and (
            kind == mujoco.mjtJoint.mjJNT_SLIDE
            or (kind == mujoco.mjtJoint.mjJNT_HINGE and not model.jnt_pos[joint].any())
        )
    )
    if not local:
        others.append((i, parent, child))
        return
    adr = int(model.jnt_qposadr[joint])
    q0 = float(model.qpos0[adr])
    x, y, z = (float(v) for v in model.body_pos[child])
    w, qx, qy, qz = (float(v) for v in model.body_quat[child])
    ux, uy, uz = (float(v) for v in model.jnt_axis[joint])
    if kind == mujoco.mjtJoint.mjJNT_HINGE:
        # body_quat * (0, axis): the part of the pose's quaternion that sin(h) multiplies
        b = (
            -qx * ux - qy * uy - qz * uz,
            w * ux + qy * uz - qz * uy,
            w * uy - qx * uz + qz * ux,
            w * uz + qx * uy - qy * ux,
        )
        hinges.append((i, adr, q0, (x, y, z), (w, qx, qy, qz), b))
    else:
        axis = np.empty(3)
        mujoco.mju_rotVecQuat(axis, model.jnt_axis[joint], model.body_quat[child])
        ax, ay, az = (float(v) for v in axis)
        slides.append((i, adr, q0, (x, y, z), (ax, ay, az), (w, qx, qy, qz)))


def _can_move(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    """Whether ``body``'s pose in ``ancestor``'s frame can change (a joint or mocap body on
    the way up; a body that is not a descendant counts as moving)."""
    b = body
    while b != ancestor:
        if b == 0 or model.body_jntnum[b] > 0 or model.body_mocapid[b] >= 0:
            return True
        b = int(model.body_parentid[b])
    return False


def relative_pose(
    parent_xyz: Sequence[float],
    parent_quat: Sequence[float],
    child_xyz: Sequence[float],
    child_quat: Sequence[float],
) -> tuple[Vec, Quat]:
    """The child's pose in its parent's frame, from both world poses (quaternions w-x-y-z)."""
    w, x, y, z = parent_quat[0], -parent_quat[1], -parent_quat[2], -parent_quat[3]
    dx = child_xyz[0] - parent_xyz[0]
    dy = child_xyz[1] - parent_xyz[1]
    dz = child_xyz[2] - parent_xyz[2]
    # v + w t + u x t with t = 2 u x v: the difference rotated by the parent's inverse
    tx = 2.0 * (y * dz - z * dy)
    ty = 2.0 * (z * dx - x * dz)
    tz = 2.0 * (x * dy - y * dx)
    xyz = (
        dx + w * tx + (y * tz - z * ty),
        dy + w * ty + (z * tx - x * tz),
        dz + w * tz + (x * ty - y * tx),
    )
    bw, bx, by, bz = child_quat
    quat = (
        w * bw - x * bx - y * by - z * bz,
        w * bx + x * bw + y * bz - z * by,
        w * by - x * bz + y * bw + z * bx,
        w * bz + x * by - y * bx + z * bw,
    )
    return xyz, quat
