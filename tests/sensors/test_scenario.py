"""The ``sensors:`` list of a scenario: validated with the scenario, passed to the session."""

from __future__ import annotations

import pytest

from harness.scenario import Scenario, ScenarioError
from tests.sensors.sensor_helpers import RIG


def _scenario(sensors: list) -> dict:
    return {"name": "s", "robots": [{"robot": str(RIG), "name": "rig"}], "sensors": sensors}


def test_scenario_sensors_are_kept() -> None:
    sensors = [{"name": "imu", "type": "imu", "parent": "mount", "noise_stddev": 0.1}]
    scenario = Scenario.from_mapping(_scenario(sensors))
    assert scenario.sensors == tuple(sensors)


def test_a_bad_scenario_sensor_is_a_scenario_problem() -> None:
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(_scenario([{"name": "cam", "type": "camera", "parent": "mount",
                                          "width": 0}]))  # fmt: skip
    text = str(info.value)
    assert "sensors[0]" in text
    assert "width must be an integer >= 1" in text
    with pytest.raises(ScenarioError, match="sensors"):
        Scenario.from_mapping(_scenario([{"type": "camera"}]))  # no name: the schema says so
