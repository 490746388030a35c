"""harness explore's warm worlds: a robot's initial joint position and pose applied to a warm
world against the world built cold for every example.

The demo arm's sweep (tests/explore/data/sweep.yaml); each example a new value of
``robots.0.initial_positions.joint2``, or of the robot's position and yaw. ``ours``: the warm
world's ``WarmWorlds.get`` (past the examples checked against cold builds); ``limit``: the same
examples on a cold build each (:func:`harness.explore.warm.cold_world`, what a topology change
costs). Milliseconds per example, best of three passes.
"""

from __future__ import annotations

import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import yaml
from common import Row

from harness.explore import load_plan
from harness.explore.parameters import apply_values
from harness.explore.warm import WarmWorlds, cold_world
from harness.scenario import Scenario

DATA = Path(__file__).resolve().parents[1] / "tests" / "explore" / "data"

PARAMETERS: dict[str, dict[str, Any]] = {
    "initial position": {"robots.0.initial_positions.joint2": {"low": -0.3, "high": 0.3}},
    "pose": {
        "robots.0.position": {"low": [-0.1, -0.1, 0.0], "high": [0.1, 0.1, 0.0]},
        "robots.0.orientation": {"low": [0.0, 0.0, -0.5], "high": [0.0, 0.0, 0.5]},
    },
}


def _values(kind: str, n: int) -> list[dict[str, Any]]:
    steps = [-1.0 + 2.0 * i / (n - 1) for i in range(n)]
    if kind == "initial position":
        return [{"robots.0.initial_positions.joint2": 0.3 * s} for s in steps]
    return [
        {"robots.0.position": [0.1 * s, -0.1 * s, 0.0], "robots.0.orientation": [0.0, 0.0, 0.5 * s]}
        for s in steps
    ]


def _ms_per_example(kind: str, n: int, folder: Path) -> tuple[float, float]:
    doc = yaml.safe_load((DATA / "sweep.yaml").read_text())
    doc["explore"] = {"parameters": PARAMETERS[kind]}
    folder.mkdir(parents=True)
    source = folder / "sweep.yaml"
    source.write_text(yaml.safe_dump(doc, sort_keys=False))
    plan = load_plan(source)
    scenarios = []
    for values in _values(kind, n):
        concrete = apply_values(plan.document, plan.parameters, values)
        scenario = Scenario.from_mapping(concrete, base_dir=DATA, source=source)
        scenarios.append((scenario, concrete))
    worlds = WarmWorlds(folder / "warm")
    for scenario, concrete in scenarios[: 1 + worlds.checks]:
        worlds.get(scenario, concrete)
    timed = scenarios[1 + worlds.checks :]
    warm = cold = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for scenario, concrete in timed:
            worlds.get(scenario, concrete)
        warm = min(warm, (time.perf_counter() - start) / len(timed))
        start = time.perf_counter()
        for scenario, _ in timed:
            cold_world(scenario, folder / "cold")
        cold = min(cold, (time.perf_counter() - start) / len(timed))
    assert worlds.notes == [], worlds.notes
    return warm * 1000, cold * 1000


def run(quick: bool) -> list[Row]:
    n = 10 if quick else 24
    rows = []
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for kind, bar in (("initial position", 3.0), ("pose", 1.2)):
            warm, cold = _ms_per_example(kind, n, Path(tmp) / kind.replace(" ", "-"))
            rows.append(
                Row(
                    name=f"explore: a robot's {kind} on a warm world (vs cold)",
                    ours=warm,
                    limit=cold,
                    unit="ms",
                    target=f">= {bar:g}x faster than cold",
                    passed=cold / warm >= bar,
                    higher_is_better=False,
                )
            )
    return rows
