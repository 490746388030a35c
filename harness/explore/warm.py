"""A warm world per worker: the world of a scenario built once per *topology*, its values
applied per example.

An example's concrete scenario (:meth:`harness.explore.plan.ExplorePlan.text`) differs from
the one before in a few values. Some values only change numbers in the compiled model; the
rest change what the world is made of. :func:`topology_key` tells them apart:

- values (applied to a warm world): each object's ``position``, ``orientation``, ``size``,
  ``mass`` (a mass given or not is topology: it makes the object free) and ``friction`` (given
  or not is topology: absent, the scene's default applies); each robot's ``position`` and
  ``orientation`` (its pose) and the values of its ``initial_joint_positions`` (which joints
  it names is topology); and keys that are not part of the world at all: ``seed`` and
  ``sensors`` (with their noise: the session's options), ``duration``, ``script``,
  ``criteria``, ``name``;
- topology: everything else (the map, the robots and their other keys, sensors,
  controllers, the clock, ...): a new key builds a new world as ``harness run`` builds it
  (:func:`harness.scenario.scenario_session`, then :func:`harness.models.load_world`, kept
  open as a :class:`harness.models.WorldBuild`), kept for the next example of that key.

How values are applied, each as ``load_world`` derives what depends on it
(:mod:`harness.models.world.rebuild` lists what that is):

- a robot's pose: :meth:`harness.models.WorldBuild.place` runs the second half of
  ``load_world`` again (first compile, servo gains, floor placement, self-collision pairs,
  keyframes, final compile) on a copy of the world as staged (robots read and attached),
  the robots' frames at their new poses and the objects' values set first: about half a
  cold build's time for the demo arm (most of it the self-collision pairs sampled again at
  the new pose, as ``load_world`` samples them: in world coordinates, a pair touching at
  exactly zero distance may flip with the pose's rounding);
- a robot's initial positions alone: :meth:`harness.models.WorldBuild.rekey` puts them in
  the combined keyframes (``home``'s ``qpos``, the position servos' ``ctrl`` and command
  filter ``act``), from the same first compile; nothing else depends on them (the servos are
  tuned at the source's own ``home``);
- objects: the world's ``MjSpec`` gets each object's new pose, size and mass exactly as
  ``harness run`` gets them (the generated scene file writes numbers with 6 significant
  digits, :func:`mjcf_number`), and is compiled again: the compiler recomputes what depends on
  them (inertia, bounding volumes, ``mj_setConst``). A free object's place in the keyframes
  (``load_world`` copies the first compile's ``qpos0`` into them) is copied from a first
  compile, then the spec is compiled once more.

The world an example gets has the robots' views of its model (placement, ``home``); its
``mjcf``, ``mjb``, ``sha256`` and ``sources`` are those of the last build of its topology
(nothing records a warm world: a kept example is run, and recorded, by ``harness run``'s
path), and the session plan's robots carry the example's poses and initial positions.

Checked, not assumed: the first examples of each topology on the warm path
(:attr:`WarmWorlds.checks`) are also built cold and the two compiled models
(``mj_saveModel`` bytes) must be equal; when they are not, that example runs on the cold
world, the topology is built cold from then on, and :attr:`WarmWorlds.notes` says so (an
error of the search: :mod:`harness.explore.kernel`). The explore run's kept examples compare
again, against ``harness run``'s recording (:mod:`harness.explore.kernel`).
"""

from __future__ import annotations

import dataclasses
import json
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.models import (
    LoadedWorld,
    Pose,
    RobotModel,
    RobotSpec,
    WorldBuild,
    WorldObject,
    load_world,
    set_object_values,
)
from harness.scenario import (
    Scenario,
    ScenarioSession,
    effective_timestep,
    robot_pose,
    scenario_session,
)

__all__ = ["WarmWorld", "WarmWorlds", "cold_world", "mjcf_number", "model_bytes", "topology_key"]

_OBJECT_VALUES = ("position", "orientation", "size", "mass", "friction")
_ROBOT_VALUES = ("position", "orientation")
_NOT_WORLD = ("seed", "sensors", "duration", "script", "criteria", "name", "explore")


def topology_key(document: Mapping[str, Any]) -> str:
    """What must be equal for two concrete scenarios to share a warm world (see the module
    docstring): the document without its value keys, as canonical JSON."""
    doc = {k: v for k, v in document.items() if k not in _NOT_WORLD}
    objects = doc.get("objects")
    if isinstance(objects, list):
        doc["objects"] = [
            {k: v for k, v in o.items() if k not in _OBJECT_VALUES}
            | {"free": "mass" in o, "friction": "friction" in o}
            if isinstance(o, dict)
            else o
            for o in objects
        ]
    robots = doc.get("robots")
    if isinstance(robots, list):
        doc["robots"] = [_robot_topology(r) if isinstance(r, dict) else r for r in robots]
    return json.dumps(doc, sort_keys=True, default=str)


def _robot_topology(robot: Mapping[str, Any]) -> dict[str, Any]:
    out = {k: v for k, v in robot.items() if k not in _ROBOT_VALUES}
    initial = out.get("initial_joint_positions")
    if isinstance(initial, dict):  # which joints, not where
        out["initial_joint_positions"] = sorted(initial)
    return out


def mjcf_number(value: float) -> float:
    """``value`` as it comes back from an MJCF file MuJoCo wrote (6 significant digits: the
    scene ``harness run`` generates for a map with objects)."""
    return float(f"{float(value):g}")


def model_bytes(model: mujoco.MjModel) -> bytes:
    """The compiled model as ``mj_saveModel`` writes it (what a recording attaches)."""
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def _robots(planned: ScenarioSession) -> list[RobotSpec]:
    robots = planned.load.robots
    assert robots is not None
    assert not isinstance(robots, LoadedWorld)
    return list(robots)


def cold_world(scenario: Scenario, folder: Path) -> tuple[ScenarioSession, LoadedWorld]:
    """The world of ``scenario`` as ``harness run`` builds it (its generated scene in
    ``folder``)."""
    planned = scenario_session(scenario, folder)
    load = planned.load
    world = load_world(
        _robots(planned), scene=load.scene, objects=load.objects, mesh_collision=load.mesh_collision
    )
    return planned, world


def _kept_world(scenario: Scenario, folder: Path) -> tuple[ScenarioSession, WorldBuild]:
    """:func:`cold_world`, kept open for other robot poses and initial positions (the same
    world: a :class:`harness.models.WorldBuild` is ``load_world``)."""
    planned = scenario_session(scenario, folder)
    load = planned.load
    build = WorldBuild(
        _robots(planned), scene=load.scene, objects=load.objects, mesh_collision=load.mesh_collision
    )
    return planned, build


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """``spec`` compiled again, without the warning ``load_world`` already dropped (a robot
    attached with an empty prefix: its names stay its own)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*empty prefix", category=UserWarning)
        return spec.compile()


def _set_objects(spec: mujoco.MjSpec, objects: Sequence[WorldObject]) -> None:
    """Each object's values on ``spec`` as the scene file ``harness run`` writes gives them."""
    for obj in objects:
        pose = obj.pose if isinstance(obj.pose, Pose) else Pose()
        set_object_values(spec.body(obj.name), spec.geom(obj.name), obj, pose, number=mjcf_number)


def robot_values(robots: Sequence[RobotSpec], scenario: Scenario) -> list[RobotSpec]:
    """``robots`` (a topology's requests) with ``scenario``'s robot poses and initial joint
    positions, as :func:`harness.scenario.scenario_session` plans them."""
    return [
        dataclasses.replace(
            spec, pose=robot_pose(robot), initial_positions=dict(robot.initial_joint_positions)
        )
        for spec, robot in zip(robots, scenario.robots, strict=True)
    ]


@dataclass(frozen=True)
class _Warm(LoadedWorld):
    """A world with values applied: its combined description is its placements' (it depends
    on the robots, their placements and descriptions, never on an object's values), made
    once per placement instead of for every example (the simulation, the loggers and the
    traces each ask)."""

    combined: RobotModel | None = field(default=None, compare=False, repr=False)

    def combined_description(self) -> RobotModel:
        """The placements' combined description (see the class docstring)."""
        return self.combined if self.combined is not None else super().combined_description()


@dataclass
class WarmWorld:
    """One topology's world: the session plan of its first example, its world kept open
    (``build``), the step of its scenarios, whether values may be applied to it (``warm``;
    False once a check against a cold build failed) and how many warm examples were checked
    (``checked``). ``placed``: examples whose robot poses were applied
    (:meth:`harness.models.WorldBuild.place`), ``rekeyed``: examples whose robots' initial
    positions alone changed (:meth:`harness.models.WorldBuild.rekey`)."""

    planned: ScenarioSession
    build: WorldBuild
    timestep: float
    objects: tuple[WorldObject, ...]
    warm: bool = True
    checked: int = 0
    description: tuple[tuple[Pose, ...], RobotModel] | None = None
    placed: int = 0
    rekeyed: int = 0

    @property
    def world(self) -> LoadedWorld:
        """The world of the topology's last build."""
        return self.build.world

    def apply(self, scenario: Scenario) -> tuple[ScenarioSession, LoadedWorld]:
        """The session plan and world of ``scenario`` with its values (see the module
        docstring): a fresh compiled model each call (a Simulation may change its model's
        options)."""
        build = self.build
        robots = robot_values(_robots(self.planned), scenario)
        planned = dataclasses.replace(
            self.planned,
            scenario=scenario,
            load=dataclasses.replace(self.planned.load, robots=tuple(robots)),
        )
        objects = scenario.objects
        if [r.pose for r in robots] != [r.pose for r in build.requests]:
            with warnings.catch_warnings():  # the topology's cold build warned once
                warnings.simplefilter("ignore")
                world = build.place(robots, edit=lambda spec: _set_objects(spec, objects))
            self.placed += 1
            return planned, self._world(world, world.model, world.robots)
        if [r.initial_positions for r in robots] != [r.initial_positions for r in build.requests]:
            build.rekey(robots)
            self.rekeyed += 1
        spec = build.world.spec
        _set_objects(spec, objects)
        model = _compile(spec)
        free = [o.name for o in objects if o.mass is not None]
        if free and spec.keys:
            for name in free:
                adr = int(model.jnt_qposadr[model.joint(f"{name}_joint").id])
                for key in spec.keys:
                    qpos = np.array(key.qpos, dtype=float)
                    qpos[adr : adr + 7] = model.qpos0[adr : adr + 7]
                    key.qpos = qpos
            model = _compile(spec)
        return planned, self._world(build.world, model, build.views(model))

    def _world(self, world: LoadedWorld, model: mujoco.MjModel, views: Any) -> LoadedWorld:
        placements = tuple(v.placement for v in views)
        if self.description is None or self.description[0] != placements:
            self.description = (
                placements,
                dataclasses.replace(world, robots=views).combined_description(),
            )
        fields = {f.name: getattr(world, f.name) for f in dataclasses.fields(LoadedWorld)}
        return _Warm(**{**fields, "model": model, "robots": views}, combined=self.description[1])


@dataclass
class WarmWorlds:
    """One worker's warm worlds by :func:`topology_key` (see the module docstring); generated
    scenes go to ``folder``. ``builds``: cold builds made; ``applied``: examples served by
    applying values; ``notes``: topologies whose check against a cold build failed."""

    folder: Path
    worlds: dict[str, WarmWorld] = field(default_factory=dict)
    builds: int = 0
    applied: int = 0
    notes: list[str] = field(default_factory=list)
    limit: int = 16
    """Topologies kept at once (oldest dropped first)."""
    checks: int = 3
    """Warm examples of each topology also built cold and compared (the first ones)."""

    def get(
        self, scenario: Scenario, document: Mapping[str, Any]
    ) -> tuple[ScenarioSession, LoadedWorld, float]:
        """The session plan (for this ``scenario``), world and step of ``scenario``, whose
        document is ``document``."""
        key = topology_key(document)
        entry = self.worlds.get(key)
        if entry is None:
            self.builds += 1
            planned, build = _kept_world(scenario, self.folder)
            entry = WarmWorld(planned, build, effective_timestep(scenario), scenario.objects)
            if len(self.worlds) >= self.limit:
                self.worlds.pop(next(iter(self.worlds)))
            self.worlds[key] = entry
            world = build.world
        elif not entry.warm:
            planned, world = self._cold(scenario)
        else:
            planned, world = entry.apply(scenario)
            self.applied += 1
            if entry.checked < self.checks:
                entry.checked += 1
                _, cold = self._cold(scenario)
                if model_bytes(cold.model) != model_bytes(world.model):
                    entry.warm = False
                    self.notes.append(
                        f"values applied to a warm world gave another model than a cold "
                        f"build (objects {[o.name for o in scenario.objects]}, robots "
                        f"{[r.namespace for r in world.robots]}): this topology is built "
                        "cold from now on"
                    )
                    world = cold
        return planned, world, entry.timestep

    def _cold(self, scenario: Scenario) -> tuple[ScenarioSession, LoadedWorld]:
        self.builds += 1
        return cold_world(scenario, self.folder)
