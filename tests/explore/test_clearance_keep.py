"""``ClearanceLogger.keep``/``settle`` (the quiet run's clearance): the steps' poses kept and
measured in one pass at the end give the minimum ``observe`` at each step gives: the same
distance, step and pair, with the table and the floor (a plane: always measured) in or out,
for obstacles near, far and in the arm's sweep (a penetration: a negative minimum)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from harness.events import ClearanceLogger, StepContext
from harness.explore import load_plan
from harness.explore.parameters import apply_values
from harness.explore.warm import WarmWorlds
from harness.scenario import Scenario, robot_links
from harness.session import CoreOptions, SessionCore
from harness.sim import ContactSet
from tests.explore.conftest import DATA

SCRIPT = [
    ({"joint1": -1.2, "joint2": 0.2, "joint4": -1.6}, 0),
    ({"joint1": 0.0}, 250),
    ({"joint1": 1.2}, 500),
]


def _pair(world: Any, rate: float | None, ignore: list[tuple[str, str]]) -> list[ClearanceLogger]:
    return [
        ClearanceLogger(world.model, robot_bodies=robot_links(world), ignore=ignore, rate_hz=rate)
        for _ in range(2)
    ]


@pytest.mark.parametrize("position", [[0.3, -0.5, 0.5], [0.2, 0.55, 0.5], [0.9, 0.9, 0.5]])
@pytest.mark.parametrize(
    ("rate", "ignore"), [(100.0, [("*", "box")]), (None, []), (50.0, [("*", "table")])]
)
def test_kept_steps_settle_to_the_minimum_observed_at_each(
    tmp_path: Path, position: list[float], rate: float | None, ignore: list[tuple[str, str]]
) -> None:
    plan = load_plan(DATA / "sweep.yaml")
    values = {"objects.obstacle.position": position}
    document = apply_values(plan.document, plan.parameters, values)
    scenario = Scenario.from_mapping(document, base_dir=plan.source.parent, source=plan.source)
    _, world, _ = WarmWorlds(tmp_path).get(scenario, document)
    observed, kept = _pair(world, rate, ignore)
    core = SessionCore(world, CoreOptions(clock="lockstep"))
    core.start()
    sim = core.sim
    empty = ContactSet.empty()
    due = 0
    period = observed.period_ns
    for k in range(750):
        for positions, at in SCRIPT:
            if at == k:
                core.set_positions(positions)
        core.control.before_step()
        sim.step()
        t = sim.sim_time_ns
        if t >= due:  # when the session's hub calls it
            due = (t // period + 1) * period if period else 0
            context = StepContext(sim.step_index, t, sim.model, sim.data, empty, "arm")
            observed.observe(context)
            kept.keep(context)
    before = sim.data.geom_xpos.copy()
    kept.settle(sim.model, sim.data)
    assert (sim.data.geom_xpos == before).all()  # the run's poses put back
    assert kept.minimum == observed.minimum
    assert observed.minimum.step > 0
