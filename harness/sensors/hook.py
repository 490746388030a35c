"""The few lines a session needs: its robots' sensors (:func:`session_sensors`), where their
configuration goes in a recording (:func:`record_metadata`) and a robot's sensors as the state
interfaces its controllers may read (:func:`sensor_interfaces`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import mujoco

from harness.models import LoadedRobot, LoadedWorld
from harness.sensors.render import RendererInfo
from harness.sensors.spec import SensorSpec
from harness.sensors.suite import (
    METADATA_RECORD,
    RobotMount,
    SensorStateInterfaces,
    SensorSuite,
)

__all__ = ["record_metadata", "sensor_interfaces", "session_sensors"]


def session_sensors(
    robot: LoadedRobot | LoadedWorld,
    model: mujoco.MjModel,
    extra: Iterable[Mapping[str, Any] | SensorSpec],
    *,
    namespace: str,
    seed: int,
    dt_ns: int,
) -> SensorSuite | None:
    """The sensors of a session's robot(s) (declared in their files) plus ``extra``; None
    when there are none (then nothing of the sensors runs, OpenGL included)."""
    world: list[RobotMount] = []
    if isinstance(robot, LoadedRobot):  # its sources hold the scene's too
        robots = [RobotMount(namespace, "", robot.sources)]
    else:
        robots = [RobotMount(v.namespace, v.prefix, v.sources) for v in robot.robots]
        scene = {k: v for k, v in robot.sources.items() if k.startswith("scene/")}
        if scene:
            world.append(RobotMount("", "", scene))
    return SensorSuite.for_robots(model, robots, extra, seed=seed, dt_ns=dt_ns, world=world)


def record_metadata(suite: SensorSuite, recorder: object) -> None:
    """Write the sensor configuration to ``recorder`` (a metadata record
    :data:`~harness.sensors.suite.METADATA_RECORD`), and the OpenGL strings once a camera
    starts rendering; recorders without ``write_metadata`` (replay's checker) are skipped."""
    write = getattr(recorder, "write_metadata", None)
    if write is None:
        return
    write(METADATA_RECORD, suite.metadata())

    def renderer(info: RendererInfo) -> None:
        write(METADATA_RECORD + ".renderer", info.to_metadata())

    suite.on_renderer = renderer


class _NoInterfaces:
    """The state interfaces of a session without sensors."""

    names: tuple[str, ...] = ()

    def claim(self, names: Iterable[str]) -> None:
        """Nothing to keep."""

    def values(self) -> dict[str, float]:
        """None."""
        return {}


def sensor_interfaces(
    suite: SensorSuite | None, namespace: str
) -> SensorStateInterfaces | _NoInterfaces:
    """The sensors of the robot with ``namespace`` as ros2_control state interfaces
    (``<sensor>/<interface>``), for its controller manager."""
    return _NoInterfaces() if suite is None else suite.interfaces(namespace)
