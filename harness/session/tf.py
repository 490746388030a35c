"""The robots' transform tree as ``robot_state_publisher`` publishes it: one transform per
link from its parent link (the description's joint parent → child, not a flat tree under
``world``), the root links from ``world``. Transforms that cannot change go on the latched
``/tf_static`` once (fixed joints, sensor mounts, a base fixed to the world); the others on
``/tf`` at its rate (moving joints, floating bases, mocap bodies).

A transform is moving when anything between the parent's and the child's MuJoCo bodies can
move: a joint of a body on the path, or a mocap body. Poses come from the simulation's own
kinematics, so the tree composes to exactly the world poses the simulation has.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models import RobotModel
from harness.session.topics import stamp

__all__ = ["WORLD_FRAME", "RobotFrames", "TfEdge", "TfTree", "transforms_msg"]

F64 = npt.NDArray[np.float64]

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
                if bid < 0:
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
                        robot.prefix + parent,
                        body,
                        _can_move(model, bid, pid),
                    )
                edges.append(edge)
        self.edges = tuple(edges)
        self.static = tuple(e for e in edges if not e.moving)
        """The transforms of ``/tf_static``."""
        self.moving = tuple(e for e in edges if e.moving)
        """The transforms of ``/tf``."""

    def message(
        self, edges: tuple[TfEdge, ...], poses: Mapping[str, tuple[F64, F64]], sim_time_ns: int
    ) -> dict[str, Any]:
        """The ``tf2_msgs/msg/TFMessage`` of ``edges`` from the bodies' world ``poses``
        (:meth:`harness.sim.Simulation.link_poses`)."""
        if not edges:
            return {"transforms": []}
        identity = (np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))
        parent = [identity if e.parent_body is None else poses[e.parent_body] for e in edges]
        child = [poses[e.child_body] for e in edges]
        xyz, quat = relative(
            np.array([p[0] for p in parent]),
            np.array([p[1] for p in parent]),
            np.array([c[0] for c in child]),
            np.array([c[1] for c in child]),
        )
        return transforms_msg(
            sim_time_ns, [e.parent for e in edges], [e.child for e in edges], xyz, quat
        )


def _can_move(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    """Whether ``body``'s pose in ``ancestor``'s frame can change (a joint or mocap body on
    the way up; a body that is not a descendant counts as moving)."""
    b = body
    while b != ancestor:
        if b == 0 or model.body_jntnum[b] > 0 or model.body_mocapid[b] >= 0:
            return True
        b = int(model.body_parentid[b])
    return False


def relative(parent_xyz: F64, parent_quat: F64, child_xyz: F64, child_quat: F64) -> tuple[F64, F64]:
    """Each child's pose in its parent's frame (rows of world positions, quaternions w-x-y-z)."""
    conj = parent_quat * np.array([1.0, -1.0, -1.0, -1.0])
    xyz = _rotate(conj, child_xyz - parent_xyz)
    return xyz, _multiply(conj, child_quat)


def _multiply(a: F64, b: F64) -> F64:
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=1,
    )


def _rotate(q: F64, v: F64) -> F64:
    w = q[:, :1]
    u = q[:, 1:]
    t = 2.0 * np.cross(u, v)
    rotated: F64 = v + w * t + np.cross(u, t)
    return rotated


def transforms_msg(
    sim_time_ns: int, parents: list[str], children: list[str], xyz: F64, quat: F64
) -> dict[str, Any]:
    """A ``tf2_msgs/msg/TFMessage``: transform ``i`` takes ``children[i]`` into
    ``parents[i]`` (rows of ``xyz`` and ``quat`` w-x-y-z)."""
    time = stamp(sim_time_ns)
    transforms = []
    for parent, child, (x, y, z), (w, qx, qy, qz) in zip(
        parents, children, xyz.tolist(), quat.tolist(), strict=True
    ):
        transforms.append(
            {
                "header": {"stamp": time, "frame_id": parent},
                "child_frame_id": child,
                "transform": {
                    "translation": {"x": x, "y": y, "z": z},
                    "rotation": {"x": qx, "y": qy, "z": qz, "w": w},
                },
            }
        )
    return {"transforms": transforms}
