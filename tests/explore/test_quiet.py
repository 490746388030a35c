"""The quiet run (harness.explore.quiet): a passing example's result without the loggers'
per-step work is the full run's result, and only a pass is ever taken from it.

- Over the sweep's obstacle box (passes and collisions), a free ball dropped by the table
  (world contacts all along) and moveit_resources' panda sweeping past a post: every
  example's verdict, signature, reason, margins and state digest are the full kernel's;
  the passes ran quiet (but for one right after a failure), the failures did not.
- A step with a contact the verdicts judge ends the quiet run (None); with
  ``criteria.world_collisions`` a world objects' contact does too.
- What the quiet run does not cover is named (sensors, logging destinations,
  returns_to_start, a free-running clock) and runs in full.
- A quiet run that differs from the full one is an error of the search, and that world runs
  in full from then on.
- ``ControlHost.quiet_until``: skipping ``before_step`` where it says nothing is due gives the
  same states, bit for bit, as calling it at every step, with a trajectory in progress on the
  harness's own topic (the multiplexer busy at every step) and at the controllers' rate.
"""

from __future__ import annotations

import json
import random
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from harness.explore import KernelRunner, load_plan
from harness.explore.kernel import QUIET_CHECKS, run_core
from harness.explore.parameters import apply_values
from harness.explore.quiet import quiet_blocker, quiet_run
from harness.explore.warm import WarmWorlds
from harness.models import load_robot
from harness.scenario import Scenario
from harness.session import CoreOptions, SessionCore
from tests.explore.conftest import DATA, write_variant

BALL = {
    # a free ball dropped on or by the table: its contacts with the table, the box and the
    # floor are world contacts; for some places it rolls into the arm
    "objects": [
        {"name": "obstacle", "shape": "sphere", "size": [0.04], "mass": 0.2,
         "position": [0.45, 0.0, 0.35]},
    ],
    "explore": {
        "parameters": {
            "objects.obstacle.position": {"low": [0.3, -0.3, 0.35], "high": [0.6, 0.3, 0.35]}
        },
        "target": "min_clearance",
    },
}  # fmt: skip


def _key(example: Any) -> tuple[Any, ...]:
    return (example.passed, example.signature, example.reason, example.margins, example.digest)


def _values(plan: Any, rng: random.Random) -> dict[str, Any]:
    values: dict[str, Any] = {}
    for p in plan.parameters:
        values[p.path] = [
            lo + (hi - lo) * rng.random() for lo, hi in zip(p.low, p.high, strict=True)
        ]
    return values


def _scenario(plan: Any, values: dict[str, Any]) -> tuple[Scenario, dict[str, Any]]:
    document = apply_values(plan.document, plan.parameters, values)
    scenario = Scenario.from_mapping(document, base_dir=plan.source.parent, source=plan.source)
    return scenario, document


@pytest.mark.parametrize(("source", "failures"), [("sweep", 3), ("ball", 0), ("panda", 1)])
def test_quiet_examples_are_the_full_runs(tmp_path: Path, source: str, failures: int) -> None:
    if source == "ball":
        path = write_variant(tmp_path, "ball.yaml", "sweep.yaml", BALL)
    else:  # the demo arm, and moveit_resources' panda (a description we did not write)
        path = DATA / ("sweep.yaml" if source == "sweep" else "panda_sweep.yaml")
    plan = load_plan(path)
    quiet = KernelRunner(plan, tmp_path / "quiet")
    full = KernelRunner(plan, tmp_path / "full", quiet=False)
    rng = random.Random(5)
    passed = failed = 0
    after_failure = False
    for _ in range(16):
        values = _values(plan, rng)
        before = quiet.quiet_runs
        a, b = quiet.run(values), full.run(values)
        assert _key(a) == _key(b), values
        # passes only, and not right after a failure (while shrinking most examples fail)
        assert a.quiet == (b.passed and not after_failure), values
        assert quiet.quiet_runs - before == int(a.quiet)
        after_failure = not b.passed
        passed += b.passed
        failed += not b.passed
    assert quiet.mismatches == []
    assert full.quiet_runs == 0
    assert passed >= 3, passed
    assert failed >= failures, failed  # the sweep: both kinds were compared


def test_a_judged_contact_ends_the_quiet_run(tmp_path: Path) -> None:
    plan = load_plan(write_variant(tmp_path, "ball.yaml", "sweep.yaml", BALL))
    worlds = WarmWorlds(tmp_path / "worlds")
    # the ball falls to the floor, away from the arm: world contacts only, quiet
    scenario, document = _scenario(plan, {"objects.obstacle.position": [-0.55, 0.55, 0.345]})
    planned, world, timestep = worlds.get(scenario, document)
    assert quiet_run(scenario, planned, world, timestep) is not None
    # the same, with world objects' contacts judged: not a quiet pass
    judged = dict(document, criteria={**document["criteria"], "world_collisions": True})
    strict = Scenario.from_mapping(judged, base_dir=plan.source.parent, source=plan.source)
    planned, world, timestep = worlds.get(strict, judged)
    assert quiet_run(strict, planned, world, timestep) is None
    # the sweep's post in the arm's path: the arm touches it, not a quiet pass
    plan = load_plan(DATA / "sweep.yaml")
    scenario, document = _scenario(plan, {"objects.obstacle.position": [0.3, -0.5, 0.5]})
    planned, world, timestep = worlds.get(scenario, document)
    assert not run_core(scenario, planned, world, timestep)[0].passed
    assert quiet_run(scenario, planned, world, timestep) is None


@pytest.mark.parametrize(
    ("edit", "reason"),
    [
        (
            {"sensors": [{"name": "wrist_ft", "type": "force_torque", "joint": "joint7",
                          "update_rate": 100}]},
            "sensors",
        ),
        (
            {"logging": {"enable": True, "destination": [{"type": "JsonLines",
                                                           "path": "events.jsonl"}]}},
            "logging destinations",
        ),
        ({"clock": {"mode": "fast"}}, "a fast clock"),
    ],
)  # fmt: skip
def test_what_a_quiet_run_does_not_cover_runs_in_full(
    tmp_path: Path, edit: dict[str, Any], reason: str
) -> None:
    plan = load_plan(write_variant(tmp_path, "variant.yaml", "clear.yaml", edit))
    values = {p.path: p.nominal for p in plan.parameters}
    scenario, document = _scenario(plan, values)
    planned, _, _ = WarmWorlds(tmp_path / "worlds").get(scenario, document)
    assert quiet_blocker(scenario, planned) == reason
    runner = KernelRunner(plan, tmp_path / "scratch")
    example = runner.run(values)
    assert example.passed
    assert runner.quiet_runs == 0


def test_a_quiet_run_unlike_the_full_one_is_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import harness.explore.kernel as kernel

    def skewed(*args: Any, **kwargs: Any) -> Any:
        outcome = quiet_run(*args, **kwargs)
        assert outcome is not None
        result, margin = outcome
        import dataclasses

        return dataclasses.replace(result, state_digest="0" * 64), margin

    monkeypatch.setattr(kernel, "quiet_run", skewed)
    plan = load_plan(DATA / "clear.yaml")
    runner = KernelRunner(plan, tmp_path / "scratch")
    values = {p.path: p.nominal for p in plan.parameters}
    first = runner.run(values)
    assert len(runner.mismatches) == 1
    assert "quiet run and the full run differ" in runner.mismatches[0]
    assert first.digest != "0" * 64  # the full run's answer was used
    assert not first.quiet
    runner.run(values)  # that world now runs in full: no quiet run, no second mismatch
    assert runner.quiet_runs == 1
    assert len(runner.mismatches) == 1


def test_quiet_passes_are_checked_then_trusted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import harness.explore.kernel as kernel

    full_runs: list[int] = []
    real = kernel.run_core

    def counted(*args: Any, **kwargs: Any) -> Any:
        full_runs.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(kernel, "run_core", counted)
    plan = load_plan(DATA / "clear.yaml")
    runner = KernelRunner(plan, tmp_path / "scratch")
    values = {p.path: p.nominal for p in plan.parameters}
    for _ in range(QUIET_CHECKS + 3):
        assert runner.run(values).passed
    assert runner.quiet_runs == QUIET_CHECKS + 3
    assert len(full_runs) == QUIET_CHECKS  # the first ones also ran in full, then not


ARM = [f"joint{i}" for i in range(1, 8)]


def _trajectory_frame() -> str:
    msg = {
        "joint_names": ARM,
        "points": [
            {"positions": [0.3, -0.5, 0.2, -2.1, 0.1, 1.8, 0.9],
             "time_from_start": {"sec": 0, "nanosec": 300_000_000}},
        ],
    }  # fmt: skip
    return json.dumps({"op": "publish", "topic": "/joint_trajectory", "msg": msg})


def _core() -> SessionCore:
    core = SessionCore(load_robot("demo", control="position"), CoreOptions(clock="lockstep"))
    core.start()
    core.publish_initial()
    return core


def test_quiet_until_skips_only_what_does_nothing() -> None:
    every_step, quiet = _core(), _core()
    control = quiet.control
    every = control.robots[0].every
    assert every > 1
    assert control.quiet_until(1) == every  # the next update cycle
    skipped = 0
    for core in (every_step, quiet):
        for k in range(400):
            if k == 20:  # a trajectory on the harness's topic: the multiplexer works each step
                core.replay_frame(1, "publish", "/joint_trajectory", _trajectory_frame())
                if core is quiet:
                    assert control.quiet_until(20) == 20
            if core is every_step or k >= control.quiet_until(k):
                core.control.before_step()
            elif core is quiet:
                skipped += 1
            core.sim.step()
    assert skipped > 150  # before and after the trajectory (every step while it moves)
    assert control.quiet_until(400) % every == 0  # idle again after its end
    assert np.array_equal(every_step.sim.get_state(), quiet.sim.get_state())
    assert np.array_equal(every_step.sim.data.qpos, quiet.sim.data.qpos)


def test_mujoco_keeps_the_contacts_where_the_quiet_run_looks(tmp_path: Path) -> None:
    """What the quiet run's contact check relies on (a MuJoCo upgrade that breaks it fails
    here, and the quiet run then ends on its own guard): the contacts' geom ids stay at one
    address through a run whose contacts come and go, and a view made earlier reads the
    current contacts while their number is the same."""
    plan = load_plan(DATA / "sweep.yaml")
    scenario, document = _scenario(plan, {"objects.obstacle.position": [0.3, -0.5, 0.5]})
    _, world, _ = WarmWorlds(tmp_path).get(scenario, document)
    core = SessionCore(world, CoreOptions(clock="lockstep"))
    core.start()
    core.set_positions({"joint1": -1.2, "joint2": 0.2, "joint4": -1.6})
    sim = core.sim
    addresses, counts, live = set(), set(), 0
    view = sim.data.contact.geom
    for k in range(750):
        if k == 250:
            core.set_positions({"joint1": 0.0})
        core.control.before_step()
        sim.step()
        current = sim.data.contact.geom
        if sim.data.ncon:
            addresses.add(current.__array_interface__["data"][0])
        if len(view) == len(current) and len(current):
            assert view.tobytes() == current.tobytes()
            live += 1
        counts.add(sim.data.ncon)
        view = current
    assert len(addresses) == 1
    assert len(counts) >= 3  # contacts came and went (the arm hits the post)
    assert live > 500
