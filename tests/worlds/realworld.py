"""Helpers of the real-world tests (issue 33): a TurtleBot3 in a Gazebo world at its launch
pose, driven through ``/cmd_vel`` over the bridge, checked against an independent ray cast.

The ray cast is trimesh's (``trimesh.ray.ray_triangle``), of the world's collision shapes
built from their sizes and, for meshes, from the triangles the model holds (the mesh itself,
not the convex pieces MuJoCo collides): only the intersection is independent of MuJoCo, which
is what the lidar's ``mj_multiRay`` is checked for.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.events import CollectingSink, CollisionEnd, CollisionLogger
from harness.scenario import CollisionSummary, Criteria, judge
from harness.session import Session
from harness.testing import BridgeTestClient, connect

DATA = Path(__file__).resolve().parents[1] / "data" / "worlds"
TB3 = DATA / "turtlebot3"
TB3_MODELS = TB3 / "models"
HOUSE_DECOMPOSITION = TB3 / "decomposition"
"""turtlebot3_house's decomposition cache entries, vendored (see its README.md)."""


@dataclass
class Run:
    """A session of one robot in a world, its bridge client and its collision events."""

    session: Session
    client: BridgeTestClient
    sink: CollectingSink

    def ends(self) -> list[CollisionEnd]:
        return [e for e in self.sink.events if isinstance(e, CollisionEnd)]

    def base_qpos(self) -> np.ndarray:
        """The robot's free joint: x y z qw qx qy qz (a world's free models come first)."""
        model = self.session.model
        links = set(self.session.link_names)
        (joint,) = [
            j
            for j in range(model.njnt)
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
            and model.body(int(model.jnt_bodyid[j])).name in links
        ]
        address = int(model.jnt_qposadr[joint])
        return np.array(self.session.sim.data.qpos[address : address + 7])

    def base_xy_yaw(self) -> tuple[float, float, float]:
        qpos = self.base_qpos()
        w, x, y, z = (float(v) for v in qpos[3:7])
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return float(qpos[0]), float(qpos[1]), yaw

    def robot_ends(self) -> list[CollisionEnd]:
        """The ends of the robot's own contact episodes."""
        links = set(self.session.link_names)
        return [e for e in self.ends() if e.body1 in links or e.body2 in links]

    def drive(self, linear: float, angular: float, steps: int) -> None:
        self.client.publish(
            "/cmd_vel",
            "geometry_msgs/msg/Twist",
            {
                "linear": {"x": linear, "y": 0.0, "z": 0.0},
                "angular": {"x": 0.0, "y": 0.0, "z": angular},
            },
        )
        self.client.step(steps)

    def go_to(self, x: float, y: float, *, tolerance: float = 0.02, max_steps: int = 40000) -> None:
        """Closed loop on the true pose (the robot's own odometry would do as well): turn to
        the point, then drive to it, a command every 50 ms of simulation time."""
        every = max(1, round(0.05e9 / self.session.dt_ns))
        for _ in range(max_steps // every):
            px, py, yaw = self.base_xy_yaw()
            dx, dy = x - px, y - py
            distance = math.hypot(dx, dy)
            if distance < tolerance:
                break
            error = (math.atan2(dy, dx) - yaw + math.pi) % (2 * math.pi) - math.pi
            angular = max(-1.0, min(1.0, 2.0 * error))
            linear = 0.0 if abs(error) > 0.3 else min(0.2, distance)
            self.drive(linear, angular, every)
        self.drive(0.0, 0.0, every)

    def verdict(self) -> tuple[bool, str]:
        """The default collision verdict (``harness run``'s ``criteria.no_collisions`` with
        every default) of the episodes so far."""
        dt = self.session.dt_ns / 1e9
        links = set(self.session.link_names)
        summaries = []
        for e in self.ends():
            body1, body2 = (e.body1, e.body2) if e.body1 in links else (e.body2, e.body1)
            summaries.append(
                CollisionSummary(
                    body1,
                    body2,
                    e.begin_step * dt,
                    None if e.at_finish else e.end_step * dt,
                    e.penetration,
                    e.normal_force,
                    world=body1 not in links,
                    initial=e.begin_step == 0,
                    support=e.support,
                )
            )
        (collisions,) = [
            v for v in judge(Criteria(), None, summaries, ()) if v.name == "collisions"
        ]
        return collisions.passed, collisions.detail


@contextlib.contextmanager
def open_run(
    robot: Path, world: Path, pose: Sequence[float], record: Path, **keywords: Any
) -> Iterator[Run]:
    """A lockstep session of ``robot`` at ``pose`` in ``world``, recorded to ``record``,
    with a collision logger over the robot's links. Every joint velocity-driven: the
    DiffDrive plugin's wheels follow /cmd_vel so (``mode="velocity"``, what works today; the
    plugin becomes velocity-driven by itself with issue 34)."""
    sink = CollectingSink()

    def logger(session: Session) -> CollisionLogger:
        return CollisionLogger(session.model, robot_bodies=session.link_names)

    with (
        Session(
            robot,
            world=world,
            pose=list(pose),
            clock="lockstep",
            record_to=record,
            loggers=[logger],
            sinks=[sink],
            mode="velocity",
            **keywords,
        ) as session,  # fmt: skip
        connect(session.url) as client,
    ):
        yield Run(session, client, sink)


def world_triangles(model: mujoco.MjModel, data: mujoco.MjData, robot: set[int]) -> Any:
    """The world's collision shapes as one trimesh (world frame): boxes, cylinders, spheres,
    planes (a 100 m square) and each mesh's own triangles; the convex pieces (``#`` in the
    name) and the robot's bodies left out."""
    import trimesh

    parts = []
    for g in range(model.ngeom):
        name = model.geom(g).name
        if int(model.geom_bodyid[g]) in robot or "#" in name:
            continue
        kind = int(model.geom_type[g])
        size = model.geom_size[g]
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            part = trimesh.creation.box(extents=2 * size)
        elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            part = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=128)
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            part = trimesh.creation.icosphere(subdivisions=4, radius=size[0])
        elif kind == mujoco.mjtGeom.mjGEOM_PLANE:
            part = trimesh.creation.box(extents=(100.0, 100.0, 1e-3))
        elif kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = int(model.geom_dataid[g])
            start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
            fstart, fcount = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
            vertices = model.mesh_vert[start : start + count]
            faces = model.mesh_face[fstart : fstart + fcount]
            part = trimesh.Trimesh(vertices, faces, process=False)
        else:
            continue
        transform = np.eye(4)
        transform[:3, :3] = data.geom_xmat[g].reshape(3, 3)
        transform[:3, 3] = data.geom_xpos[g]
        part.apply_transform(transform)
        parts.append(part)
    return trimesh.util.concatenate(parts)


def ray_cast_ranges(
    triangles: Any, origin: np.ndarray, rotation: np.ndarray, angles: np.ndarray, range_max: float
) -> np.ndarray:
    """The first hit along each horizontal ray of the sensor frame (``inf``: none in range)."""
    import trimesh

    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    directions = directions @ rotation.T
    origins = np.repeat(origin[np.newaxis, :], len(angles), axis=0)
    caster = trimesh.ray.ray_triangle.RayMeshIntersector(triangles)
    locations, index_ray, _ = caster.intersects_location(origins, directions, multiple_hits=True)
    ranges = np.full(len(angles), np.inf)
    for point, ray in zip(locations, index_ray, strict=True):
        distance = float(np.linalg.norm(point - origin))
        if distance < ranges[ray]:
            ranges[ray] = distance
    ranges[ranges > range_max] = np.inf
    return ranges
