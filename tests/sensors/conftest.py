"""Shared fixtures of the sensor tests: the rig model (tests/data/sensors/sensor_rig.xml) and
a suite of sensors on it, read at a step without a session."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import mujoco
import pytest

from harness.sensors import RobotMount, SensorSuite
from tests.sensors.sensor_helpers import RIG

Read = Callable[..., dict[str, Mapping[str, Any]]]


class Rig:
    """The rig's model and data with a suite of ``sensors`` (mappings as in a scenario)."""

    def __init__(self, sensors: Sequence[Mapping[str, Any]], seed: int = 0) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(RIG))
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)
        dt_ns = round(self.model.opt.timestep * 1e9)
        suite = SensorSuite.for_robots(
            self.model, [RobotMount("", "", {})], sensors, seed=seed, dt_ns=dt_ns
        )
        assert suite is not None
        self.suite = suite
        self.dt_ns = dt_ns

    def read(self, step: int = 0) -> dict[str, Mapping[str, Any]]:
        """Every message due at ``step`` (the state is the rig's current one), by topic."""
        return {
            d.output.topic: d.build() for d in self.suite.due(self.data, step, step * self.dt_ns)
        }

    def close(self) -> None:
        self.suite.close()


@pytest.fixture
def rig() -> Callable[..., Rig]:
    made: list[Rig] = []

    def make(sensors: Sequence[Mapping[str, Any]], seed: int = 0) -> Rig:
        made.append(Rig(sensors, seed))
        return made[-1]

    yield make  # type: ignore[misc]
    for r in made:
        r.close()
