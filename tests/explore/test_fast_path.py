"""No shortcut in the fast path.

- A warm world with an example's values applied is the world a cold build makes: the same
  compiled model, byte for byte (``mj_saveModel``), also when sizes and masses change (a
  stale derived value, an inertia or a bounding sphere, would show).
- An example run by the generation kernel (a bare core, no Session, nothing recorded)
  computes what ``harness run`` computes: verdict, signature, margins, state digest; a kept
  example's recording (the product's run) is byte-identical to a cold ``harness run`` of its
  concrete scenario; a difference is an error of the search, not hidden.
- For every failure found and 20 random passing examples, the recording an explore example
  kept is byte-identical to a cold ``harness run`` of its concrete scenario
  (``harness.explore.run_scenario``: the loader, specs and runner ``harness run`` uses,
  stepping 10 steps per request as ``harness run`` does).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from harness.explore import (
    ExploreError,
    KernelRunner,
    SearchOptions,
    load_plan,
    run_scenario,
    search,
)
from harness.explore.parameters import apply_values
from harness.explore.warm import WarmWorlds, cold_world, model_bytes
from harness.scenario import Scenario
from tests.explore.conftest import DATA, write_variant

KNOCK = {
    # a free ball on the table: the arm's sweep knocks it, so its size and mass change the run
    "objects": [
        {
            "name": "obstacle",
            "shape": "sphere",
            "size": [0.04],
            "mass": 0.2,
            "position": [0.45, 0.0, 0.35],
        }
    ],
    "explore": {
        "parameters": {
            "objects.obstacle.size": {"low": [0.02], "high": [0.08]},
            "objects.obstacle.mass": {"low": 0.05, "high": 2.0},
            "objects.obstacle.position": {"low": [0.4, -0.1, 0.35], "high": [0.5, 0.1, 0.4]},
        },
        "target": "min_clearance",
    },
}
VALUES = [  # (size, mass, position): digits beyond the 6 a scene file keeps, on purpose
    ([0.0412345678901], 0.2345678901234, [0.45, 0.0123456789012, 0.35]),
    ([0.0687654321098], 1.8765432109876, [0.4123456789012, -0.05, 0.3812345678901]),
    ([0.0234567890123], 0.0567890123456, [0.4987654321098, 0.0987654321098, 0.35]),
]


def _values(size: list[float], mass: float, position: list[float]) -> dict[str, Any]:
    return {
        "objects.obstacle.size": size,
        "objects.obstacle.mass": mass,
        "objects.obstacle.position": position,
    }


def _cold_bytes(scenario: Path, out: Path) -> bytes:
    result = run_scenario(scenario, out)
    assert result.recording is not None
    return Path(result.recording).read_bytes()


def test_warm_world_is_the_cold_build_after_size_and_mass_changes(tmp_path: Path) -> None:
    plan = load_plan(write_variant(tmp_path, "knock.yaml", "sweep.yaml", KNOCK))
    worlds = WarmWorlds(tmp_path / "warm")
    for i, (size, mass, position) in enumerate(VALUES):
        doc = apply_values(plan.document, plan.parameters, _values(size, mass, position))
        scenario = Scenario.from_mapping(doc, base_dir=plan.source.parent, source=plan.source)
        _, warm, _ = worlds.get(scenario, doc)
        _, cold = cold_world(scenario, tmp_path / f"cold-{i}")
        assert model_bytes(warm.model) == model_bytes(cold.model), (size, mass, position)
        if i == 1:  # the same size set on the compiled model alone leaves derived values stale
            stale = copy.copy(cold.model)
            stale.geom_size[stale.geom("obstacle").id][0] = 0.05
            assert model_bytes(stale) != model_bytes(cold.model)
    assert worlds.notes == []
    # one build for the topology, cold builds checking its first warm examples
    assert (worlds.builds, worlds.applied) == (1 + 2, 2)
    doc = apply_values(plan.document, plan.parameters, _values(*VALUES[0]))
    worlds.get(Scenario.from_mapping(doc, base_dir=plan.source.parent, source=plan.source), doc)
    assert (worlds.builds, worlds.applied) == (1 + worlds.checks, 3)


def test_kernel_example_is_harness_run(tmp_path: Path) -> None:
    plan = load_plan(write_variant(tmp_path, "knock.yaml", "sweep.yaml", KNOCK))
    runner = KernelRunner(plan, tmp_path / "scratch")
    runner.run(_values(*VALUES[0]))  # the topology's world: later examples are warm
    signatures: list[str] = []
    for i, (size, mass, position) in enumerate(VALUES):
        recording = tmp_path / "scratch" / "recording.mcap"  # where the product's run records
        recording.unlink(missing_ok=True)
        fast = runner.run(_values(size, mass, position))
        assert fast.kept is None
        assert not list((tmp_path / "scratch").rglob("*.mcap"))
        kept = runner.run(_values(size, mass, position), keep=tmp_path / f"kept-{i}")
        assert kept.check == "identical", kept.check
        assert (kept.passed, kept.signature, kept.digest, kept.margins) == (
            fast.passed,
            fast.signature,
            fast.digest,
            fast.margins,
        )
        signatures.append(kept.signature)
        folder = Path(kept.kept or "")
        explored = (folder / "recording.mcap").read_bytes()
        assert explored == _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
    assert any("obstacle" in s for s in signatures)  # the ball was hit: size and mass matter
    assert runner.mismatches == []
    assert runner.kernel_runs == 1 + 2 * len(VALUES)
    assert len({runner.run(_values(*v)).digest for v in VALUES}) == len(VALUES)


def test_a_warm_world_that_is_not_the_cold_one_is_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Values applied without the scene file's rounding give another model than harness
    run's: the search stops with an error naming it instead of searching a different world."""
    import harness.explore.warm as warm

    monkeypatch.setattr(warm, "mjcf_number", float)
    plan = load_plan(write_variant(tmp_path, "knock.yaml", "sweep.yaml", KNOCK))
    with pytest.raises(ExploreError, match="another model than a cold build"):
        search(plan, SearchOptions(work=tmp_path / "work", examples=3, seed=0))


@pytest.mark.slow
def test_explore_recordings_equal_cold_harness_run(tmp_path: Path) -> None:
    passing = search(
        load_plan(DATA / "clear.yaml"),
        SearchOptions(work=tmp_path / "clear", examples=40, keep_passing=20, seed=3),
    )
    kept_examples = [e for e in passing.examples if e.kept and e.passed]
    kept = [Path(e.kept or "") for e in kept_examples]
    assert len(kept) == 20
    assert len({(k / "scenario.yaml").read_text() for k in kept}) == 20  # 20 distinct examples
    assert {e.check for e in kept_examples} == {"identical"}  # the kernel computed the same
    failing = search(
        load_plan(DATA / "sweep.yaml"),
        SearchOptions(work=tmp_path / "sweep", examples=40, seed=1),
    )
    assert failing.failures, "the planted obstacle region was not hit in 40 examples"
    assert {t.first.check for t in failing.failures.values()} == {"identical"}
    kept += [Path(t.first.kept) for t in failing.failures.values() if t.first.kept]
    assert len(kept) == 20 + len(failing.failures)
    for i, folder in enumerate(kept):
        explored = (folder / "recording.mcap").read_bytes()
        cold = _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
        assert explored == cold, f"{folder}: the explore recording differs from harness run's"


def test_seed_and_sensor_noise_are_values_of_a_warm_world(tmp_path: Path) -> None:
    """The seed and a sensor's noise are session options: the world stays warm, and the kept
    example is still harness run's (its force-torque readings, noise drawn from the seed, are
    in the recording)."""
    sensor = {"name": "wrist_ft", "type": "force_torque", "joint": "joint7", "update_rate": 100}
    edit = {
        "sensors": [{**sensor, "noise_stddev": 0.01}],
        "explore": {
            "parameters": {
                "seed": {"integers": [0, 1000]},
                "sensors.wrist_ft.noise_stddev": {"low": 0.0, "high": 0.5},
            }
        },
    }
    plan = load_plan(write_variant(tmp_path, "noisy.yaml", "clear.yaml", edit))
    runner = KernelRunner(plan, tmp_path / "scratch")
    runner.run({"seed": 0, "sensors.wrist_ft.noise_stddev": 0.01})
    for i, (seed, noise) in enumerate([(7, 0.25), (901, 0.5)]):
        kept = runner.run(
            {"seed": seed, "sensors.wrist_ft.noise_stddev": noise}, keep=tmp_path / f"kept-{i}"
        )
        assert kept.check == "identical", kept.check
        folder = Path(kept.kept or "")
        explored = (folder / "recording.mcap").read_bytes()
        assert explored == _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
    assert len(runner.worlds.worlds) == 1  # one topology
    assert runner.worlds.applied == 2
    assert runner.mismatches == []


@pytest.mark.parametrize(
    "edit",
    [
        {"clock": {"mode": "fast"}},  # a free-running clock stepped by the script
        {"clock": {"mode": "fast"}, "script": None},  # a free-running clock to its limit
        {"script": None},  # lockstep, no script: the world holds its initial command
    ],
    ids=["fast-script", "fast-world", "lockstep-world"],
)
def test_kernel_runs_each_clock_as_harness_run(tmp_path: Path, edit: dict[str, Any]) -> None:
    plan = load_plan(write_variant(tmp_path, "variant.yaml", "sweep.yaml", edit))
    runner = KernelRunner(plan, tmp_path / "scratch")
    values = {"objects.obstacle.position": [0.3, -0.5, 0.5]}
    kept = runner.run(values, keep=tmp_path / "kept")
    assert kept.check == "identical", kept.check
    folder = Path(kept.kept or "")
    explored = (folder / "recording.mcap").read_bytes()
    assert explored == _cold_bytes(folder / "scenario.yaml", tmp_path / "cold")


SLIDE = {
    # the free ball on the table with its own friction: how far the arm's knock sends it
    # depends on it (sliding) and on the torsional and rolling values
    "objects": [
        {
            "name": "obstacle",
            "shape": "sphere",
            "size": [0.04],
            "mass": 0.2,
            "friction": [0.8, 0.005, 0.0001],
            "position": [0.45, 0.0, 0.35],
        }
    ],
    "explore": {
        "parameters": {
            "objects.obstacle.friction": {
                "low": [0.05, 0.0, 0.0],
                "high": [1.5, 0.02, 0.001],
            }
        }
    },
}


def test_friction_is_a_value_of_a_warm_world(tmp_path: Path) -> None:
    """An object's friction (a scenario key: sliding, torsional, rolling) varies on a warm
    world: the compiled model is the cold build's, the kernel's result the product's, the
    kept recording a cold ``harness run``'s; and the values reach the model."""
    plan = load_plan(write_variant(tmp_path, "slide.yaml", "sweep.yaml", SLIDE))
    runner = KernelRunner(plan, tmp_path / "scratch")
    runner.run({"objects.obstacle.friction": [0.8, 0.005, 0.0001]})  # the topology's world
    digests = set()
    for i, friction in enumerate(([0.1234567890123, 0.01, 0.0005], [1.4567890123456, 0.0, 0.0])):
        values = {"objects.obstacle.friction": friction}
        doc = apply_values(plan.document, plan.parameters, values)
        scenario = Scenario.from_mapping(doc, base_dir=plan.source.parent, source=plan.source)
        _, warm, _ = runner.worlds.get(scenario, doc)
        _, cold = cold_world(scenario, tmp_path / f"world-{i}")
        assert model_bytes(warm.model) == model_bytes(cold.model), friction
        geom = cold.model.geom("obstacle").id
        assert list(cold.model.geom_friction[geom]) == pytest.approx(friction, rel=1e-5)
        kept = runner.run(values, keep=tmp_path / f"kept-{i}")
        assert kept.check == "identical", kept.check
        digests.add(kept.digest)
        folder = Path(kept.kept or "")
        explored = (folder / "recording.mcap").read_bytes()
        assert explored == _cold_bytes(folder / "scenario.yaml", tmp_path / f"cold-{i}")
    assert len(digests) == 2  # the friction changed the run
    assert runner.worlds.applied >= 2  # applied to the warm world, not rebuilt
    assert runner.worlds.notes == []
    assert runner.mismatches == []
