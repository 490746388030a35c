""":class:`WorldBuild`: a world :func:`harness.models.load_world` built, kept to be built again
with other robot poses and initial joint positions without reading or attaching anything again.

What :func:`load_world` derives from a robot's ``pose`` and ``initial_positions`` (found by
reading it, checked by comparing compiled models byte for byte):

- ``initial_positions`` only reach the combined keyframes
  (:func:`harness.models.world.keyframes.combine_keyframes`): the ``home`` key's ``qpos``, the
  ``ctrl`` of the overridden position servos and the command filter's ``act`` of every added
  position servo. The servo gains, the placement on the floor and the ignored self-collision
  pairs are derived at the source's own ``home`` (``initial_positions`` left out), so
  :meth:`WorldBuild.rekey` runs the keyframes again, from the same first compile, on the
  finished spec: nothing else changes.
- ``pose`` reaches the robot's frame in the world and, through the first compile, almost
  everything after it: the servos' gains and any armature added (``dof_invweight0`` and the
  mass matrix at ``home`` are computed in world coordinates, so a yaw changes their last
  bits), the lift off the floor (a fixed robot reaching through it, a floating one set down),
  the ignored self-collision pairs, a floating base's free-joint ``qpos`` in the keys.
  :meth:`WorldBuild.place` runs that whole second half of :func:`load_world` again
  (:func:`harness.models.world.build.finish_world`) on a copy of the world as it was staged
  (robots read, built and attached), with the new poses set on the robots' frames.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

import mujoco

from harness.models.build.decompose import MeshCollision
from harness.models.build.robot import RobotBuild
from harness.models.description import Pose
from harness.models.errors import ModelStructureError
from harness.models.world.build import (
    FinishedWorld,
    StagedWorld,
    finish_world,
    home_positions,
    stage_world,
)
from harness.models.world.keyframes import combine_keyframes
from harness.models.world.records import (
    LoadedRobotView,
    LoadedWorld,
    RobotSpec,
    WorldObject,
    placement_pose,
)

__all__ = ["WorldBuild"]


class WorldBuild:
    """A world as :func:`harness.models.load_world` builds it (same arguments; :attr:`world`
    is what ``load_world`` returns), kept to be built again with other robot ``pose`` and
    ``initial_positions`` values (see the module docstring): :meth:`place` for poses,
    :meth:`rekey` for initial positions alone. Each gives what ``load_world`` gives for the
    same requests: the same compiled model, byte for byte."""

    def __init__(
        self,
        robots: Sequence[RobotSpec],
        *,
        scene: str | Path | None = None,
        objects: Sequence[WorldObject] = (),
        timestep: float | None = None,
        cache_dir: str | Path | None = None,
        mesh_collision: MeshCollision = "decompose",
    ) -> None:
        staged = stage_world(robots, scene, objects, timestep, cache_dir, mesh_collision)
        frames = list(staged.spec.worldbody.frames)
        self._frames = [
            None if r.frame is None else next(i for i, f in enumerate(frames) if f == r.frame)
            for r in staged.prepared
        ]
        self._staged = _copy(staged, self._frames, [r.request for r in staged.prepared])
        self._finished: FinishedWorld = finish_world(staged)
        self.requests: tuple[RobotSpec, ...] = tuple(r.request for r in staged.prepared)
        """The robots of the world as it is now (their poses and initial positions)."""

    @property
    def world(self) -> LoadedWorld:
        """The world of the last build (:meth:`place`, or the first); after :meth:`rekey`
        its spec holds the new keyframes, its model and views are still the build's."""
        return self._finished.world

    @property
    def placeable(self) -> bool:
        """Whether :meth:`place` may move a robot: False for a lone MJCF robot that is its own
        world (its top bodies were moved, no frame holds them)."""
        return not self._staged.own_world

    def place(
        self,
        robots: Sequence[RobotSpec],
        edit: Callable[[mujoco.MjSpec], None] | None = None,
    ) -> LoadedWorld:
        """The world with ``robots`` (the requests it was built from, other poses and
        initial positions allowed): the second half of ``load_world`` again (see the module
        docstring); ``edit``: changes to make to the staged spec first (an object's values).
        Becomes :attr:`world`."""
        self._check(robots)
        if not self.placeable and any(
            _pose(a) != _pose(b) for a, b in zip(robots, self._staged_requests(), strict=True)
        ):
            raise ModelStructureError(
                f"{self._staged.world_source}: the pose of a robot that is its own world "
                "cannot change (load it again)"
            )
        staged = _copy(self._staged, self._frames, list(robots))
        if edit is not None:
            edit(staged.spec)
        self._finished = finish_world(staged)
        self.requests = tuple(robots)
        return self._finished.world

    def rekey(self, robots: Sequence[RobotSpec]) -> None:
        """Put ``robots``' initial positions in the keyframes of :attr:`world`'s spec (their
        poses must be the world's: :meth:`place` otherwise); the spec is compiled by the
        caller, whose robots' views are :meth:`views`."""
        self._check(robots)
        moved = [
            i
            for i, (a, b) in enumerate(zip(robots, self.requests, strict=True))
            if a.pose != b.pose
        ]
        if moved:
            raise ModelStructureError(
                f"{self._staged.world_source}: robots{moved} moved: place() builds a new pose"
            )
        finished = self._finished
        prepared = []
        for robot, request in zip(finished.prepared, robots, strict=True):
            clone = copy.copy(robot)
            clone.request = request
            prepared.append(clone)
        combine_keyframes(finished.world.spec, finished.first, prepared, finished.several)
        finished.prepared = prepared
        self.requests = tuple(robots)

    def views(self, model: mujoco.MjModel) -> tuple[LoadedRobotView, ...]:
        """The robots' views of ``model``, compiled from :attr:`world`'s spec: :attr:`world`'s
        views with ``home`` read from ``model``'s keyframe (the rest does not depend on
        the initial positions)."""
        return tuple(
            replace(view, home=MappingProxyType(home_positions(model, view.joints)))
            for view in self.world.robots
        )

    def _staged_requests(self) -> list[RobotSpec]:
        return [r.request for r in self._staged.prepared]

    def _check(self, robots: Sequence[RobotSpec]) -> None:
        staged = self._staged_requests()
        if len(robots) != len(staged):
            raise ModelStructureError(
                f"{self._staged.world_source}: {len(robots)} robots given, the world has "
                f"{len(staged)}"
            )
        for index, (new, old) in enumerate(zip(robots, staged, strict=True)):
            if replace(new, pose=old.pose, initial_positions=old.initial_positions) != old:
                raise ModelStructureError(
                    f"{self._staged.world_source}: robots[{index}] differs in more than its "
                    "pose and initial_positions (load the world again)"
                )


def _pose(robot: RobotSpec) -> Pose | None:
    return placement_pose(robot.pose, "robot")


def _copy(staged: StagedWorld, frames: list[int | None], requests: list[RobotSpec]) -> StagedWorld:
    """A copy of ``staged`` (its spec copied, each robot's build copied with ``requests``),
    each robot's frame at its request's pose."""
    spec = staged.spec.copy()
    world_frames = list(spec.worldbody.frames)
    prepared: list[RobotBuild] = []
    placements: list[Pose | None] = []
    for robot, index, request in zip(staged.prepared, frames, requests, strict=True):
        clone = copy.copy(robot)
        clone.notes = list(robot.notes)
        clone.request = request
        placement = placement_pose(request.pose, robot.where(staged.several))
        if index is None:  # a robot that is its own world: its pose was applied when staged
            clone.frame = None
        else:
            clone.frame = world_frames[index]
            pose = placement or Pose()
            clone.frame.pos = list(pose.xyz)
            clone.frame.quat = list(pose.quat)
        prepared.append(clone)
        placements.append(placement)
    return replace(
        staged, spec=spec, prepared=prepared, placements=placements, sources=dict(staged.sources)
    )
