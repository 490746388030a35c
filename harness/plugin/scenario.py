"""The marker's ``scenario=``: the session ``harness run`` would start for the file
(:func:`harness.scenario.session_options.scenario_session`, the one translation), with the
marker's keys over it (the marker wins).

This module imports only the standard library, pytest and :mod:`harness.vocabulary` at import
time; the scenario package loads when a scenario is first translated.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from harness.plugin.markers import first_robot_keys, parse_load_options, parse_mode
from harness.vocabulary import ClockMode

__all__ = ["over_scenario", "scenario_session"]


def scenario_session(path: Path, folder: Path) -> Any:
    """The scenario's session (:func:`harness.scenario.session_options.scenario_session`: the
    translation ``harness run`` uses), with the marker's default clock (``lockstep``) when
    the file has no ``clock`` section; a bad file fails the test with its problems."""
    from harness.scenario import Clock, Scenario, ScenarioError
    from harness.scenario import scenario_session as translate

    try:
        return translate(Scenario.load(path), folder, default_clock=Clock(ClockMode.LOCKSTEP))
    except ScenarioError as exc:
        pytest.fail(str(exc), pytrace=False)


def over_scenario(planned: Any, marker: dict[str, Any], where: str) -> dict[str, Any]:
    """The scenario's Session keywords with the marker's keys over them (the marker wins):
    world-level keys replace the scenario's; ``robots`` replaces its robots; the robot keys
    (:func:`harness.plugin.markers.first_robot_keys`: ``robot``, ``mode``, ``namespace``,
    ...) apply to its first robot (a RobotSpec field each: ``source``, ``control``,
    ``namespace``, ...). ``marker`` loses the robot keys it had (they are in the first robot
    now)."""
    import dataclasses

    keywords = planned.keywords()
    keywords["port"] = 0  # a free port per test: xdist workers run side by side
    del keywords["record_to"]  # the test's own recording
    fields = first_robot_keys()
    own = {k: marker.pop(k) for k in fields if k in marker}
    if "robots" not in marker and own:
        if "mode" in own:
            own["mode"] = parse_mode(own["mode"], f"{where}: harness option 'mode'")
        parse_load_options(own, where)
        first = keywords["robots"][0]
        if "robot" in own:  # another robot: the file's joint settings are not its
            first = dataclasses.replace(first, control="position", initial_positions={})
            first = dataclasses.replace(first, robot_args={})
        first = dataclasses.replace(first, **{fields[k]: v for k, v in own.items()})
        keywords["robots"] = [first, *keywords["robots"][1:]]
    elif own:
        pytest.fail(
            f"{where}: harness options {', '.join(sorted(own))} apply to robot=; with robots= "
            "give each RobotSpec its own",
            pytrace=False,
        )
    if "world" in marker and "scene" not in marker:
        keywords.pop("scene")
    if "clock" in marker and "start" not in marker:  # as the translation starts that clock
        keywords["start"] = "now" if marker["clock"] == "lockstep" else "paused"
    return {**keywords, **marker}
