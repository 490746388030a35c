"""What the generation kernel's two runs of an example share (:func:`harness.explore.kernel.
run_core`, in full; :func:`harness.explore.quiet.quiet_run`, quiet): the example's session
options, the observer's host, the ``script`` target's commands over a bare core, and the
example's :class:`~harness.scenario.IterationResult`."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, cast

from harness.events import velocity_limits
from harness.models import LoadedWorld
from harness.scenario import (
    CollisionSummary,
    IterationObserver,
    IterationResult,
    JointLimitSummary,
    Scenario,
    ScenarioError,
    ScenarioSession,
    Verdict,
    criteria_settings,
    steps_for,
)
from harness.session import CoreOptions, SessionConfigError, SessionCore

__all__ = [
    "TRACE_SAMPLES",
    "CoreHost",
    "CoreTarget",
    "core_options",
    "example_observer",
    "example_result",
]

TRACE_SAMPLES = 500
"""About how many joint trace samples an example keeps (the session runner's default)."""


@dataclass(frozen=True)
class CoreHost:
    """What the session runner's observer reads of a session: its simulation and world."""

    sim: Any
    world: LoadedWorld


def core_options(scenario: Scenario, planned: ScenarioSession) -> CoreOptions:
    """The session options of an example: the plan's, with the example's seed and sensors
    (values of a warm world: :mod:`harness.explore.warm`)."""
    try:
        return dataclasses.replace(
            planned.options, seed=scenario.seed, sensors=tuple(scenario.sensors)
        )
    except SessionConfigError as exc:
        raise ScenarioError([f"{scenario.source}: {exc}"]) from None


def example_observer(
    scenario: Scenario, core: SessionCore, world: LoadedWorld, timestep: float
) -> IterationObserver:
    """The session runner's observer of an example's core (its trace samples about
    :data:`TRACE_SAMPLES` over the scenario's duration)."""
    expected = steps_for(scenario.duration, round(timestep * 1e9))
    every = max(1, math.ceil(expected / TRACE_SAMPLES))
    tolerance = scenario.criteria.joint_limit_tolerance
    return IterationObserver(cast(Any, CoreHost(core.sim, world)), every, tolerance)


class CoreTarget:
    """A :class:`harness.scenario.ScriptCommand` target's commands over a core: what a
    :class:`harness.session.Session`'s Python commands do, without the shell; subclasses
    step."""

    def __init__(self, core: SessionCore) -> None:
        self._core = core

    def step(self, n: int = 1) -> int:
        raise NotImplementedError

    def set_positions(self, positions: Mapping[str, float]) -> Any:
        return self._core.set_positions(dict(positions))

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> Any:
        return self._core.command(joint, position=position, velocity=velocity, effort=effort)

    @property
    def step_index(self) -> int:
        return int(self._core.sim.step_index)


def example_result(
    scenario: Scenario,
    observer: IterationObserver,
    world: LoadedWorld,
    dt_ns: int,
    verdicts: list[Verdict],
    collisions: tuple[CollisionSummary, ...],
    limits: tuple[JointLimitSummary, ...],
    notes: tuple[str, ...],
    started: float,
) -> IterationResult:
    """An example's result as the session runner makes an iteration's (nothing recorded,
    no client, no port); ``started``: its ``time.monotonic()`` at the start."""
    return IterationResult(
        simulation=scenario.name,
        iteration=1,
        verdicts=tuple(verdicts),
        sim_time=observer.step * dt_ns / 1e9,
        steps=observer.step,
        recording=None,
        collisions=collisions,
        joint_limits=limits,
        traces=observer.traces(velocity_limits(world.combined_description())),
        state_digest=observer.digest.hexdigest(),
        client=None,
        port=0,
        wall_seconds=time.monotonic() - started,
        notes=notes,
        settings=criteria_settings(scenario.criteria),
    )
