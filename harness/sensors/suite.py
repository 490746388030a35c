"""A session's sensors (:class:`SensorSuite`): what is due at a step, lazily built messages,
``/tf_static`` of the sensor frames and the recording's sensor metadata.

The session asks :meth:`SensorSuite.due` at every step and publishes/records what it returns;
the suite knows nothing of sockets or MCAP. A sensor with rate ``r`` Hz is due at step 0 and at
the first step at or after each of its periods (``n / r`` seconds), so that its mean rate is
``r`` whatever the step (every step for ``r = 0`` or ``r`` above the step rate); counted in
simulation steps, never on the wall clock.

Sensors read a private copy of the simulation state (``mj_getState``/``mj_setState`` of
``mjSTATE_INTEGRATION`` + ``mj_forward``), so the poses, velocities, accelerations, contacts and
forces they see are those of the state recorded at that step, and the simulation's own data is
never touched: a session with sensors steps bit-for-bit as one without.

A sensor kind with ros2_control state interfaces (an IMU's ``orientation.x``...) can feed a
controller: :meth:`SensorSuite.interfaces` gives a robot's sensors as ``<sensor>/<interface>``
names and values; once a controller claims some, the suite keeps the values of each claimed
sensor's last update (read at its due steps from the same copy of the state its messages are
built from), so a broadcaster publishes exactly what the sensor measured.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import mujoco
import numpy as np

from harness.sensors.base import Sensor, SensorTopic, View, mount_of
from harness.sensors.declare import declared_in_sources
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import static_tf_msg
from harness.sensors.registry import Mounted, kind_of
from harness.sensors.render import OffscreenRenderer, RendererInfo
from harness.sensors.ros2_control_sensors import ros2_control_sensors
from harness.sensors.spec import SensorSpec

__all__ = [
    "METADATA_RECORD",
    "TOPIC_TF_STATIC",
    "Due",
    "RobotMount",
    "SensorStateInterfaces",
    "SensorSuite",
]

TOPIC_TF_STATIC = "/tf_static"
METADATA_RECORD = "harness.sensors"
"""The name of the recording metadata record holding the sensor configuration."""


@dataclass(frozen=True)
class RobotMount:
    """One robot of the session as the sensors see it: its namespace, the prefix of its names
    in the model and its source files (``"<role>/<file>"`` -> bytes)."""

    namespace: str
    prefix: str
    sources: Mapping[str, bytes]


@dataclass(frozen=True)
class Due:
    """One message due now: publish/record it on ``output.topic`` (``build`` makes it)."""

    output: SensorTopic
    build: Callable[[], Mapping[str, Any]]


def _resolve(name: str, namespace: str) -> str:
    if name.startswith("/"):
        return name
    return f"/{namespace}/{name}" if namespace else f"/{name}"


class _Reading:
    """One sensor's reading at one step, made on the first message asked of it."""

    def __init__(
        self, suite: SensorSuite, sensor: Sensor, data: mujoco.MjData, step: int, time_ns: int
    ) -> None:
        self._args = (suite, sensor, data, step, time_ns)
        self._builders: Mapping[str, Callable[[], dict[str, Any]]] | None = None

    def message(self, key: str) -> Mapping[str, Any]:
        if self._builders is None:
            suite, sensor, data, step, time_ns = self._args
            self._builders = sensor.read(suite.view(data, step, time_ns))
        return self._builders[key]()


class _Schedule:
    """When a sensor of ``rate`` Hz is due: at step 0 and at the first step at or after each
    period; exact integer arithmetic (the rate as a fraction), so it repeats bit for bit."""

    def __init__(self, rate: float, dt_ns: int) -> None:
        ratio = Fraction(rate).limit_denominator(10**6) if rate else Fraction(0)
        self._num = ratio.numerator * dt_ns  # periods elapsed by step k: k * num // den
        self._den = ratio.denominator * 1_000_000_000
        self._every_step = not rate or ratio * dt_ns >= 1_000_000_000

    def due(self, step: int) -> bool:
        if self._every_step or step <= 0:
            return True
        return step * self._num // self._den != (step - 1) * self._num // self._den


class SensorSuite:
    """Every sensor of a session. ``specs`` with the robot each belongs to; ``seed``: the
    session seed (noise); ``dt_ns``: the step."""

    def __init__(
        self,
        model: mujoco.MjModel,
        specs: Sequence[tuple[SensorSpec, RobotMount]],
        *,
        seed: int,
        dt_ns: int,
    ) -> None:
        self.model = model
        self.seed = int(seed)
        self.dt_ns = dt_ns
        self.specs = tuple(spec for spec, _ in specs)
        self._renderer: OffscreenRenderer | None = None
        self.on_renderer: Callable[[RendererInfo], None] | None = None
        """Called once when the first camera frame starts OpenGL (the session records it)."""
        self.sensors: list[Sensor] = []
        self._every: list[_Schedule] = []
        self._parents: list[str] = []
        topics_seen: dict[str, str] = {}
        for spec, robot in specs:
            sensor = self._make(spec, robot)
            for out in sensor.outputs:
                if out.topic in topics_seen:
                    raise SensorConfigError(
                        f"sensor {spec.name!r}: topic {out.topic} is also sensor "
                        f"{topics_seen[out.topic]!r}'s: give one of them its own (topics:)"
                    )
                topics_seen[out.topic] = spec.name
            self.sensors.append(sensor)
            rate = spec.period_hz
            self._every.append(_Schedule(rate, dt_ns))
        self._data = mujoco.MjData(model)
        spec_int = mujoco.mjtState.mjSTATE_INTEGRATION.value
        self._state_spec = spec_int
        self._state = np.zeros(mujoco.mj_stateSize(model, spec_int))
        self._view_step = -1
        self._view: View | None = None
        self._claimed: set[int] = set()
        """The sensors whose state interfaces a controller reads."""
        self._held: dict[int, tuple[float, ...]] = {}
        """Their values at their last update."""

    def _make(self, spec: SensorSpec, robot: RobotMount) -> Sensor:
        kind = kind_of(spec.type)
        mount = mount_of(self.model, spec, robot.prefix)
        defaults = kind.default_topics(spec.topic, spec.token)
        topics = {
            key: _resolve(spec.topics.get(key, value), robot.namespace)
            for key, value in defaults.items()
        }
        frame_id = robot.prefix + (spec.frame_id or spec.token)
        self._parents.append(mount.body_name)
        sensor: Sensor = kind.build(
            spec, Mounted(self.model, mount, topics, frame_id, robot.prefix, self.renderer)
        )
        return sensor

    @classmethod
    def for_robots(
        cls,
        model: mujoco.MjModel,
        robots: Sequence[RobotMount],
        extra: Iterable[Mapping[str, Any] | SensorSpec] = (),
        *,
        seed: int,
        dt_ns: int,
        world: Sequence[RobotMount] = (),
    ) -> SensorSuite | None:
        """The sensors declared in the robots' files and the ``world`` files (scene models,
        unprefixed, topics global) plus ``extra`` (scenario/Python; an extra sensor named
        like a declared one replaces it); None when there are none."""
        found: dict[tuple[str, str], tuple[SensorSpec, RobotMount]] = {}
        by_namespace = {robot.namespace: robot for robot in robots}
        for robot in (*robots, *world):
            declared = declared_in_sources(robot.sources)
            for spec in [*declared, *ros2_control_sensors(robot.sources, declared)]:
                spec = replace(spec, namespace=robot.namespace)
                found[(spec.namespace, spec.name)] = (spec, robot)
        for i, item in enumerate(extra):
            spec = SensorSpec.from_mapping(item, f"sensors[{i}]")
            if spec.namespace not in by_namespace:
                if len(robots) == 1 and not spec.namespace:
                    spec = replace(spec, namespace=robots[0].namespace)
                else:
                    raise SensorConfigError(
                        f"sensors[{i}] ({spec.name!r}): no robot with namespace "
                        f"{spec.namespace!r} (robots: "
                        f"{', '.join(repr(r.namespace) for r in robots)})"
                    )
            # a listed sensor named like a declared one replaces it
            found[(spec.namespace, spec.name)] = (spec, by_namespace[spec.namespace])
        if not found:
            return None
        return cls(model, list(found.values()), seed=seed, dt_ns=dt_ns)

    # ------------------------------------------------------------------------------ stepping

    def renderer(self) -> OffscreenRenderer:
        """The shared offscreen renderer (OpenGL starts here, on the first camera frame)."""
        if self._renderer is None:
            sizes: list[tuple[int, int]] = [
                s.image_size  # type: ignore[attr-defined]
                for s in self.sensors
                if getattr(s, "uses_renderer", False)
            ]
            width = max(w for w, _ in sizes)
            height = max(h for _, h in sizes)
            self._renderer = OffscreenRenderer(self.model, width, height)
            if self.on_renderer is not None:
                self.on_renderer(self._renderer.info)
        return self._renderer

    @property
    def renderer_info(self) -> RendererInfo | None:
        """The OpenGL strings once a camera has rendered, else None."""
        return None if self._renderer is None else self._renderer.info

    def view(self, data: mujoco.MjData, step: int, sim_time_ns: int) -> View:
        """The sensors' copy of ``data`` at ``step`` (made once per step, on first use)."""
        if self._view is None or self._view_step != step:
            mujoco.mj_getState(self.model, data, self._state, self._state_spec)
            mujoco.mj_setState(self.model, self._data, self._state, self._state_spec)
            mujoco.mj_forward(self.model, self._data)
            self._view = View(self.model, self._data, step, sim_time_ns, self.seed)
            self._view_step = step
        return self._view

    def due(self, data: mujoco.MjData, step: int, sim_time_ns: int) -> list[Due]:
        """The messages due at ``step`` (built only when called)."""
        out: list[Due] = []
        self._view = None  # a reset may repeat a step number: never reuse an older copy
        for i in self._claimed:
            if self._every[i].due(step):
                sensor = self.sensors[i]
                self._held[i] = sensor.interface_values(  # type: ignore[attr-defined]
                    self.view(data, step, sim_time_ns)
                )
        for sensor, every in zip(self.sensors, self._every, strict=True):
            if not every.due(step):
                continue
            reading = _Reading(self, sensor, data, step, sim_time_ns)
            for output in sensor.outputs:
                out.append(Due(output, functools.partial(reading.message, output.key)))
        return out

    def interfaces(self, namespace: str) -> SensorStateInterfaces:
        """The state interfaces of the sensors of the robot with ``namespace`` (what
        :class:`harness.controllers.SensorInterfaces` asks)."""
        own = [i for i, spec in enumerate(self.specs) if spec.namespace == namespace]
        return SensorStateInterfaces(self, own)

    def claim(self, sensors: Iterable[int]) -> None:
        """Keep the state interface values of ``sensors`` (indices) from now on."""
        for i in sensors:
            self._claimed.add(i)
            names = getattr(self.sensors[i], "state_interfaces", ())
            self._held.setdefault(i, (0.0,) * len(names))

    def held(self, i: int) -> tuple[float, ...]:
        """The state interface values of sensor ``i`` at its last update."""
        return self._held[i]

    def static_tf(self, sim_time_ns: int = 0) -> dict[str, Any]:
        """The ``tf2_msgs/TFMessage`` of every sensor frame in its link (for ``/tf_static``)."""
        frames = [
            (parent, child, xyz, quat)
            for sensor, parent in zip(self.sensors, self._parents, strict=True)
            for child, xyz, quat in sensor.static_frames()
        ]
        return static_tf_msg(sim_time_ns, frames)

    def topics(self) -> list[tuple[str, str]]:
        """Every (topic, message type) the sensors publish."""
        return [(o.topic, o.msgtype) for s in self.sensors for o in s.outputs]

    def metadata(self) -> dict[str, str]:
        """The sensor configuration as recording metadata (strings)."""
        out = {
            "sensors": json.dumps([s.to_json() for s in self.specs], sort_keys=True),
            "topics": json.dumps(dict(self.topics()), sort_keys=True),
            "seed": str(self.seed),
        }
        if self._renderer is not None:
            out.update(self._renderer.info.to_metadata())
        return out

    def close(self) -> None:
        """Free the renderer (if a camera started one)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class SensorStateInterfaces:
    """Some sensors of a suite as ros2_control state interfaces ``<sensor>/<interface>``
    (the kinds that declare ``state_interfaces``)."""

    def __init__(self, suite: SensorSuite, sensors: Sequence[int]) -> None:
        self._suite = suite
        self._names: dict[int, tuple[str, ...]] = {}
        for i in sensors:
            own = tuple(getattr(suite.sensors[i], "state_interfaces", ()))
            if own:
                self._names[i] = tuple(f"{suite.specs[i].name}/{n}" for n in own)

    @property
    def names(self) -> tuple[str, ...]:
        """Every state interface, sensor by sensor."""
        return tuple(n for names in self._names.values() for n in names)

    def claim(self, names: Iterable[str]) -> None:
        """A controller reads ``names``: their sensors keep their values from now on."""
        wanted = set(names)
        self._suite.claim(i for i, own in self._names.items() if wanted.intersection(own))

    def values(self) -> dict[str, float]:
        """Interface -> value at its sensor's last update (claimed sensors only)."""
        out: dict[str, float] = {}
        for i, names in self._names.items():
            if i in self._suite._claimed:
                out.update(zip(names, self._suite.held(i), strict=True))
        return out
