"""The few lines a session needs: its robots' sensors (:func:`session_sensors`), where their
configuration goes in a recording (:func:`record_metadata`) and a robot's sensors as the state
interfaces its controllers may read (:func:`sensor_interfaces`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import mujoco

from harness.models import LoadedRobot, LoadedWorld
from harness.sensors.declare import declared_in_sources
from harness.sensors.render import RendererInfo
from harness.sensors.spec import SensorSpec
from harness.sensors.suite import (
    METADATA_RECORD,
    RobotMount,
    SensorStateInterfaces,
    SensorSuite,
)

__all__ = [
    "GROUND_TRUTH_RATE",
    "GROUND_TRUTH_TOPIC",
    "record_metadata",
    "sensor_interfaces",
    "session_sensors",
]


TYPE_GROUND_TRUTH = "ground_truth"
GROUND_TRUTH_TOPIC = "/ground_truth/odom"
"""Where a base-driven robot's true pose goes when no ``ground_truth`` sensor is declared."""
GROUND_TRUTH_RATE = 50.0  # Hz of simulation time, as the bundled mobile robot's declaration


def session_sensors(
    robot: LoadedRobot | LoadedWorld,
    model: mujoco.MjModel,
    extra: Iterable[Mapping[str, Any] | SensorSpec],
    *,
    namespace: str,
    seed: int,
    dt_ns: int,
    base_driven: Iterable[str] = (),
) -> SensorSuite | None:
    """The sensors of a session's robot(s) (declared in their files) plus ``extra``; None
    when there are none (then nothing of the sensors runs, OpenGL included).

    ``base_driven``: the namespaces of the robots a base controller drives; each with a
    floating base and no ``ground_truth`` sensor of its own gets one on its root link,
    :data:`GROUND_TRUTH_TOPIC` (global for a single robot, else under its namespace; a
    declared or listed ``ground_truth`` sensor names another topic)."""
    world: list[RobotMount] = []
    if isinstance(robot, LoadedRobot):  # its sources hold the scene's too
        robots = [RobotMount(namespace, "", robot.sources)]
        bases = {namespace: (robot.base, robot.description.root_link)}
    else:
        robots = [RobotMount(v.namespace, v.prefix, v.sources) for v in robot.robots]
        bases = {v.namespace: (v.base, v.description.root_link) for v in robot.robots}
        scene = {k: v for k, v in robot.sources.items() if k.startswith("scene/")}
        if scene:
            world.append(RobotMount("", "", scene))
    extra = list(extra)
    extra += _ground_truth(robots, extra, bases, set(base_driven), single=len(robots) == 1)
    return SensorSuite.for_robots(model, robots, extra, seed=seed, dt_ns=dt_ns, world=world)


def _ground_truth(
    robots: Sequence[RobotMount],
    extra: Sequence[Mapping[str, Any] | SensorSpec],
    bases: Mapping[str, tuple[str, str | None]],
    driven: set[str],
    *,
    single: bool,
) -> list[dict[str, Any]]:
    """The ground truth sensors the base-driven robots lack (see :func:`session_sensors`)."""
    if not driven:
        return []
    have: set[str] = set()
    for robot in robots:
        if any(s.type == TYPE_GROUND_TRUTH for s in declared_in_sources(robot.sources)):
            have.add(robot.namespace)
    for item in extra:
        kind = item.type if isinstance(item, SensorSpec) else item.get("type")
        space = item.namespace if isinstance(item, SensorSpec) else item.get("namespace", "")
        if kind == TYPE_GROUND_TRUTH:
            have.add(str(space or (robots[0].namespace if single else "")))
    out: list[dict[str, Any]] = []
    for robot in robots:
        base, root = bases.get(robot.namespace, ("fixed", None))
        if robot.namespace not in driven or robot.namespace in have:
            continue
        if base != "floating" or root is None:
            continue
        topic = GROUND_TRUTH_TOPIC if single else GROUND_TRUTH_TOPIC.lstrip("/")
        out.append(
            {
                "name": "ground_truth",
                "type": TYPE_GROUND_TRUTH,
                "parent": root,
                "topic": topic,
                "update_rate": GROUND_TRUTH_RATE,
                "namespace": robot.namespace,
                "source": "a base controller's ground truth",
            }
        )
    return out


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
