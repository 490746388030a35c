"""Run files: the original framework's runner config (``sim_runner``), or a single scenario.

Runner config mapping (original key -> ours):

- ``simulations[].ueScenario`` (or our ``scenario``) -> the scenario file, relative to the
  runner file's folder.
- ``ros2Pkg`` + ``ros2Launch`` -> the client command ``ros2 launch <ros2Pkg> <ros2Launch>``
  (``ros2Launch`` alone -> ``ros2 launch <ros2Launch>``); our ``command`` key (a string split
  like a POSIX shell, or a list) takes precedence over both; without any of them the
  scenario's own ``client`` is used, and without that the iteration runs without a client.
- ``timeout`` -> the readiness timeout: wall seconds for the client to connect to the bridge.
- ``maxSimTime`` -> the sim-time limit (seconds of simulation time; default: the scenario's
  ``duration``).
- ``restartBridge`` and ``ueProject`` are accepted and ignored, with a notice.
- ours: ``workers`` (local worker processes), ``env``, ``wall_timeout`` (the scenario
  client's spelling; ``wallTimeout`` accepted, as this format is camelCase).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from harness.scenario._validation import load_document, schema_problems
from harness.scenario.errors import ScenarioError
from harness.scenario.scenario import ClientSpec, Scenario, command_tuple

__all__ = ["RunConfig", "SimulationPlan", "load_run_file"]


@dataclass(frozen=True)
class SimulationPlan:
    """One entry of a run: a scenario run ``iterations`` times with the same client."""

    name: str
    scenario: Scenario
    iterations: int
    client: ClientSpec | None
    sim_time_limit: float


@dataclass(frozen=True)
class RunConfig:
    """A loaded run file: its simulations, the worker count it asks for, and notices about
    accepted-but-ignored keys."""

    simulations: tuple[SimulationPlan, ...]
    workers: int | None
    notices: tuple[str, ...]
    source: Path


def load_run_file(path: str | Path) -> RunConfig:
    """Load a runner config (a document with ``simulations``) or a scenario file."""
    path = Path(path).resolve()
    data = load_document(path)
    if isinstance(data, dict) and "simulations" in data:
        return _runner_config(data, path)
    scenario = Scenario.from_mapping(data, base_dir=path.parent, source=path)
    plan = SimulationPlan(
        name=scenario.name,
        scenario=scenario,
        iterations=1,
        client=scenario.client,
        sim_time_limit=scenario.duration,
    )
    return RunConfig(simulations=(plan,), workers=None, notices=(), source=path)


def _runner_config(data: dict[str, Any], path: Path) -> RunConfig:
    where = str(path)
    problems = schema_problems(data, "runner", where)
    if problems:
        raise ScenarioError(problems)
    notices = [
        f"{where}: {key}: accepted and ignored ({why})"
        for key, why in (
            ("restartBridge", "the bridge is embedded in every iteration"),
            ("ueProject", "there is no Unreal project; the scenario describes the world"),
        )
        if key in data
    ]
    plans: list[SimulationPlan] = []
    for index, sim in enumerate(data["simulations"]):
        key = f"simulations[{index}]"
        if "scenario" in sim and "ueScenario" in sim:
            problems.append(f"{where}: {key}: give 'scenario' or 'ueScenario', not both")
            continue
        scenario_file = sim.get("scenario", sim.get("ueScenario"))
        if scenario_file is None:
            problems.append(f"{where}: {key}: missing required key 'scenario' (or 'ueScenario')")
            continue
        if "ros2Pkg" in sim and "ros2Launch" not in sim and "command" not in sim:
            problems.append(f"{where}: {key}.ros2Pkg: {sim['ros2Pkg']!r} needs 'ros2Launch'")
        scenario_key = "scenario" if "scenario" in sim else "ueScenario"
        try:
            scenario = Scenario.load(path.parent / scenario_file)
        except ScenarioError as exc:
            problems.extend(f"{where}: {key}.{scenario_key}: {p}" for p in exc.problems)
            continue
        plans.append(
            SimulationPlan(
                name=sim.get("name", scenario.name),
                scenario=scenario,
                iterations=sim.get("iterations", 1),
                client=_client(sim, scenario, path.parent),
                sim_time_limit=float(sim.get("maxSimTime", scenario.duration)),
            )
        )
    names = [p.name for p in plans]
    for name in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"{where}: simulations: name {name!r} is used more than once")
    if problems:
        raise ScenarioError(problems)
    return RunConfig(
        simulations=tuple(plans), workers=data.get("workers"), notices=tuple(notices), source=path
    )


def _client(sim: dict[str, Any], scenario: Scenario, base: Path) -> ClientSpec | None:
    if "command" in sim:
        command: tuple[str, ...] | None = command_tuple(sim["command"])
    elif "ros2Launch" in sim:
        pkg = (sim["ros2Pkg"],) if "ros2Pkg" in sim else ()
        command = ("ros2", "launch", *pkg, sim["ros2Launch"])
    else:
        command = None
    client = scenario.client
    if command is not None:
        client = (
            ClientSpec(command=command, cwd=base)
            if client is None
            else replace(client, command=command, cwd=base)
        )
    if client is None:
        return None
    if "env" in sim:
        client = replace(client, env={**client.env, **sim["env"]})
    if "timeout" in sim:
        client = replace(client, readiness_timeout=float(sim["timeout"]))
    wall_timeout = sim.get("wall_timeout", sim.get("wallTimeout"))
    if wall_timeout is not None:
        client = replace(client, wall_timeout=float(wall_timeout))
    return client
