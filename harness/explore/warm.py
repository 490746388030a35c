"""A warm world per worker: the world of a scenario built once per *topology*, its values
applied per example.

An example's concrete scenario (:meth:`harness.explore.plan.ExplorePlan.text`) differs from
the one before in a few values. Some values only change numbers in the compiled model; the
rest change what the world is made of. :func:`topology_key` tells them apart:

- values (applied to a warm world): each object's ``position``, ``orientation``, ``size``,
  ``mass`` (a mass given or not is topology: it makes the object free) and ``friction`` (given
  or not is topology: absent, the scene's default applies), and keys that
  are not part of the world at all: ``seed`` and ``sensors`` (with their noise: the
  session's options), ``duration``, ``script``, ``criteria``, ``name``;
- topology: everything else (the map, the robots with their initial joint positions and
  pose, sensors, controllers, the clock, ...): a new key builds a new world as ``harness
  run`` builds it (:func:`harness.scenario.scenario_session`, then
  :func:`harness.models.load_world`), kept for the next example of that key.

A robot's initial joint positions and pose are topology here: ``load_world`` derives the
position servos' gains (the held inertias), the floor placement and the combined keyframe
from them, so only a rebuild gives the cold model.

How values are applied: the world's ``MjSpec`` (the one ``load_world`` compiled) gets each
object's new pose, size and mass exactly as ``harness run`` gets them (the generated scene
file writes numbers with 6 significant digits, :func:`mjcf_number`), and is compiled again:
the compiler recomputes what depends on them (inertia, bounding volumes, ``mj_setConst``).
A free object's place in the keyframes (``load_world`` copies the first compile's
``qpos0`` into them) is copied from a first compile, then the spec is compiled once more.

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
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.models import (
    LoadedWorld,
    Pose,
    RobotModel,
    WorldObject,
    load_world,
    set_object_values,
)
from harness.scenario import Scenario, ScenarioSession, effective_timestep, scenario_session

__all__ = ["WarmWorld", "WarmWorlds", "cold_world", "mjcf_number", "model_bytes", "topology_key"]

_OBJECT_VALUES = ("position", "orientation", "size", "mass", "friction")
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
    return json.dumps(doc, sort_keys=True, default=str)


def mjcf_number(value: float) -> float:
    """``value`` as it comes back from an MJCF file MuJoCo wrote (6 significant digits: the
    scene ``harness run`` generates for a map with objects)."""
    return float(f"{float(value):g}")


def model_bytes(model: mujoco.MjModel) -> bytes:
    """The compiled model as ``mj_saveModel`` writes it (what a recording attaches)."""
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def cold_world(scenario: Scenario, folder: Path) -> tuple[ScenarioSession, LoadedWorld]:
    """The world of ``scenario`` as ``harness run`` builds it (its generated scene in
    ``folder``)."""
    planned = scenario_session(scenario, folder)
    load = planned.load
    robots = load.robots
    assert robots is not None
    assert not isinstance(robots, LoadedWorld)
    world = load_world(
        list(robots), scene=load.scene, objects=load.objects, mesh_collision=load.mesh_collision
    )
    return planned, world


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """``spec`` compiled again, without the warning ``load_world`` already dropped (a robot
    attached with an empty prefix: its names stay its own)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*empty prefix", category=UserWarning)
        return spec.compile()


@dataclass(frozen=True)
class _Warm(LoadedWorld):
    """A world with values applied: its combined description is its topology's (it depends
    on the robots, their placements and descriptions, never on an object's values), made
    once instead of for every example (the simulation, the loggers and the traces each ask)."""

    combined: RobotModel | None = field(default=None, compare=False, repr=False)

    def combined_description(self) -> RobotModel:
        """The topology's combined description (see the class docstring)."""
        return self.combined if self.combined is not None else super().combined_description()


@dataclass
class WarmWorld:
    """One topology's world: the session plan and world of its first example, the step of
    its scenarios, whether values may be applied to it (``warm``; False once a check
    against a cold build failed) and how many warm examples were checked (``checked``)."""

    planned: ScenarioSession
    world: LoadedWorld
    timestep: float
    objects: tuple[WorldObject, ...]
    warm: bool = True
    checked: int = 0
    description: RobotModel | None = None

    def apply(self, objects: tuple[WorldObject, ...]) -> LoadedWorld:
        """The world with ``objects``' values (see the module docstring): a fresh compiled
        model each call (a Simulation may change its model's options)."""
        spec = self.world.spec
        for obj in objects:
            pose = obj.pose if isinstance(obj.pose, Pose) else Pose()
            set_object_values(
                spec.body(obj.name), spec.geom(obj.name), obj, pose, number=mjcf_number
            )
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
        if self.description is None:
            self.description = self.world.combined_description()
        fields = {f.name: getattr(self.world, f.name) for f in dataclasses.fields(LoadedWorld)}
        return _Warm(**{**fields, "model": model}, combined=self.description)


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
            planned, world = self._cold(scenario)
            entry = WarmWorld(planned, world, effective_timestep(scenario), scenario.objects)
            if len(self.worlds) >= self.limit:
                self.worlds.pop(next(iter(self.worlds)))
            self.worlds[key] = entry
        elif not entry.warm:
            _, world = self._cold(scenario)
        else:
            world = entry.apply(scenario.objects)
            self.applied += 1
            if entry.checked < self.checks:
                entry.checked += 1
                _, cold = self._cold(scenario)
                if model_bytes(cold.model) != model_bytes(world.model):
                    entry.warm = False
                    self.notes.append(
                        f"values applied to a warm world gave another model than a cold "
                        f"build (objects {[o.name for o in scenario.objects]}): this "
                        "topology is built cold from now on"
                    )
                    world = cold
        return dataclasses.replace(entry.planned, scenario=scenario), world, entry.timestep

    def _cold(self, scenario: Scenario) -> tuple[ScenarioSession, LoadedWorld]:
        self.builds += 1
        return cold_world(scenario, self.folder)
