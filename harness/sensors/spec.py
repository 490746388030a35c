"""One sensor's declaration (:class:`SensorSpec`), whatever file or list it came from.

The same keys are spelled the same in a scenario's ``sensors:`` list, the ``sensors=`` option of
:class:`harness.Session` and the recording's sensor metadata (:meth:`SensorSpec.to_json`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal, get_args

from harness.sensors.errors import SensorConfigError, UnknownSensorType
from harness.sensors.registry import kind_of, known_types

__all__ = ["SensorSpec", "SensorType", "sensor_token"]

SensorType = str
"""A sensor type: one a module of the sensors room registers (:mod:`harness.sensors.registry`)."""
FtFrame = Literal["child", "parent", "sensor"]
FtDirection = Literal["child_to_parent", "parent_to_child"]


def sensor_token(name: str) -> str:
    """The sanitised form of a sensor name (any text, as Gazebo takes it) used where the name
    becomes part of a ROS name or frame (a default topic, the default frame, the camera's
    sensor frame): every character but letters, digits, ``_``, ``-`` and ``/`` becomes ``_``
    (``{prefix}camera_color`` -> ``_prefix_camera_color``). A name made of those only is
    itself."""
    return "".join(c if c.isalnum() or c in "_-/" else "_" for c in name)


@dataclass(frozen=True)
class SensorSpec:
    """A declared sensor (validated on creation).

    ``parent``: the link (MuJoCo body) it is mounted on; ``pose``: x y z roll pitch yaw of the
    sensor frame in the link frame (x forward, z up, as Gazebo); ``joint``: a force-torque
    sensor's joint (its child link is ``parent``); ``camera``/``site``: an MJCF camera or site
    whose pose (and for a camera its field of view) the sensor takes instead of ``pose``.
    ``update_rate``: Hz of simulation time (0: every step). ``topic``: the base topic name
    (relative names go under the robot's namespace); ``topics``: per-output overrides (the
    outputs of its kind, :attr:`harness.sensors.registry.SensorKind.outputs`). ``frame_id``:
    the sensor frame (default: the sensor name); cameras publish in ``<frame_id>_optical``
    (z forward, x right, y down). Camera: ``width``, ``height``,
    ``hfov`` (rad), ``near``/``far`` clip (m), ``record``: ``"raw"`` records ``Image``,
    ``"compressed"`` records the PNG ``CompressedImage`` instead. Lidar: horizontal ``samples``
    from ``min_angle`` to ``max_angle`` (rad), ``vertical_samples`` from ``vertical_min_angle``
    to ``vertical_max_angle``, ``range_min``/``range_max``/``range_resolution`` (m). Noise:
    Gaussian ``noise_mean``/``noise_stddev`` (ranges and depth in m; IMU on each angular
    velocity (rad/s) and linear acceleration (m/s^2) axis, ``accel_noise_mean``/
    ``accel_noise_stddev`` for the acceleration when they differ; force-torque on each axis),
    drawn from the session seed. Force-torque: ``ft_frame`` (``child`` link, ``parent`` link or the
    ``sensor`` frame) and ``ft_direction``. Contact: ``collision``, a geom name (default every
    geom of the link). ``namespace``: the robot's (set by the loader).

    ``name`` is any text without control characters, as Gazebo takes it (an upstream file may
    write ``{prefix}camera``); where it stands in for a ROS name (the default topic and frame)
    its sanitised form :attr:`token` is used. Topics and frames the file gives must be ROS
    names."""

    name: str
    type: SensorType
    parent: str = ""
    pose: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    joint: str = ""
    camera: str = ""
    site: str = ""
    update_rate: float | None = None
    topic: str = ""
    topics: Mapping[str, str] = field(default_factory=dict)
    frame_id: str = ""
    width: int = 320
    height: int = 240
    hfov: float = 1.047
    near: float = 0.05
    far: float = 100.0
    record: Literal["raw", "compressed"] = "raw"
    samples: int = 360
    min_angle: float = -math.pi
    max_angle: float = math.pi
    vertical_samples: int = 1
    vertical_min_angle: float = 0.0
    vertical_max_angle: float = 0.0
    range_min: float = 0.1
    range_max: float = 30.0
    range_resolution: float = 0.0
    noise_mean: float = 0.0
    noise_stddev: float = 0.0
    accel_noise_mean: float | None = None
    accel_noise_stddev: float | None = None
    ft_frame: FtFrame = "child"
    ft_direction: FtDirection = "child_to_parent"
    collision: str = ""
    namespace: str = ""
    source: str = ""
    """Where it was declared (a file name, ``scenario``), for error messages."""

    def __post_init__(self) -> None:
        where = f"sensor {self.name!r}" + (f" ({self.source})" if self.source else "")
        if not isinstance(self.name, str) or not self.name.strip():
            raise SensorConfigError(f"{where}: the name must be non-empty text")
        if any(not c.isprintable() for c in self.name):
            raise SensorConfigError(f"{where}: the name must not hold a control character")
        try:
            kind = kind_of(self.type)
        except UnknownSensorType:
            raise UnknownSensorType(
                f"{where}: type {self.type!r} is not one of {', '.join(known_types())}"
            ) from None
        if not (self.parent or self.joint or self.camera or self.site):
            raise SensorConfigError(f"{where}: give the link (parent) it is mounted on")
        if self.type == "force_torque" and not (self.joint or self.site or self.parent):
            raise SensorConfigError(f"{where}: a force_torque sensor needs a joint")
        try:
            pose = tuple(float(v) for v in self.pose)
        except (TypeError, ValueError):
            pose = ()
        if len(pose) != 6 or not all(math.isfinite(v) for v in pose):
            raise SensorConfigError(
                f"{where}: pose must be 6 finite numbers (x y z roll pitch yaw)"
            )
        object.__setattr__(self, "pose", pose)
        if self.update_rate is None:
            object.__setattr__(self, "update_rate", kind.rate)
        self._positive(where, "update_rate", self.update_rate, zero=True)
        for name in ("width", "height", "samples", "vertical_samples"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise SensorConfigError(f"{where}: {name} must be an integer >= 1, not {value!r}")
        for name in ("hfov", "near", "far", "range_max"):
            self._positive(where, name, getattr(self, name))
        for name in ("range_min", "range_resolution", "noise_stddev"):
            self._positive(where, name, getattr(self, name), zero=True)
        if self.accel_noise_stddev is not None:
            self._positive(where, "accel_noise_stddev", self.accel_noise_stddev, zero=True)
        if self.accel_noise_mean is not None and not (
            isinstance(self.accel_noise_mean, int | float) and math.isfinite(self.accel_noise_mean)
        ):
            raise SensorConfigError(f"{where}: accel_noise_mean must be a finite number")
        for name in ("min_angle", "max_angle", "vertical_min_angle", "vertical_max_angle",
                     "noise_mean"):  # fmt: skip
            value = getattr(self, name)
            if not isinstance(value, int | float) or not math.isfinite(value):
                raise SensorConfigError(f"{where}: {name} must be a finite number, not {value!r}")
        if self.hfov >= math.pi:
            raise SensorConfigError(f"{where}: hfov must be below pi rad, not {self.hfov!r}")
        if self.near >= self.far:
            raise SensorConfigError(f"{where}: near clip {self.near} must be below far {self.far}")
        if self.range_min >= self.range_max:
            raise SensorConfigError(
                f"{where}: range_min {self.range_min} must be below range_max {self.range_max}"
            )
        if self.min_angle > self.max_angle or self.vertical_min_angle > self.vertical_max_angle:
            raise SensorConfigError(f"{where}: a min angle is above its max angle")
        if self.record not in ("raw", "compressed"):
            raise SensorConfigError(f"{where}: record must be 'raw' or 'compressed'")
        if self.ft_frame not in get_args(FtFrame):
            raise SensorConfigError(f"{where}: ft_frame must be child, parent or sensor")
        if self.ft_direction not in get_args(FtDirection):
            raise SensorConfigError(
                f"{where}: ft_direction must be child_to_parent or parent_to_child"
            )
        topics = dict(self.topics)
        for key, value in topics.items():
            if key not in kind.outputs:
                raise SensorConfigError(
                    f"{where}: topics has {key!r}; a {self.type} has {', '.join(kind.outputs)}"
                )
            if not isinstance(value, str) or not value:
                raise SensorConfigError(f"{where}: topics[{key!r}] must be a topic name")
        object.__setattr__(self, "topics", MappingProxyType(topics))

    @staticmethod
    def _positive(where: str, name: str, value: object, zero: bool = False) -> None:
        ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
        if not ok or value < 0 or (value == 0 and not zero):  # type: ignore[operator]
            bound = ">= 0" if zero else "> 0"
            raise SensorConfigError(f"{where}: {name} must be a number {bound}, not {value!r}")

    @property
    def token(self) -> str:
        """The name as it appears in default topics and frames (:func:`sensor_token`)."""
        return sensor_token(self.name)

    @property
    def period_hz(self) -> float:
        """The update rate (never None after validation)."""
        assert self.update_rate is not None
        return float(self.update_rate)

    @classmethod
    def from_mapping(cls, value: object, where: str = "sensors") -> SensorSpec:
        """A spec from a scenario/Python mapping (keys as the fields; ``pose`` a list of 6)."""
        if isinstance(value, SensorSpec):
            return value
        if not isinstance(value, Mapping):
            raise SensorConfigError(f"{where}: a sensor must be a mapping, not {value!r}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(str(k) for k in value if k not in known)
        if unknown:
            raise SensorConfigError(
                f"{where}: unknown sensor key {unknown[0]!r} (known: {', '.join(sorted(known))})"
            )
        for key in ("name", "type"):
            if key not in value:
                raise SensorConfigError(f"{where}: a sensor needs {key!r}")
        kwargs: dict[str, Any] = dict(value)
        kwargs.setdefault("source", where)
        if "pose" in kwargs:
            pose = kwargs["pose"]
            if not isinstance(pose, list | tuple) or len(pose) != 6:
                raise SensorConfigError(
                    f"{where}: sensor {value['name']!r}: pose must be 6 numbers (x y z r p y)"
                )
            kwargs["pose"] = tuple(pose)
        if "topics" in kwargs and not isinstance(kwargs["topics"], Mapping):
            raise SensorConfigError(f"{where}: sensor {value['name']!r}: topics must be a mapping")
        try:
            return cls(**kwargs)
        except TypeError as exc:
            raise SensorConfigError(f"{where}: sensor {value['name']!r}: {exc}") from None

    def to_json(self) -> dict[str, Any]:
        """Every field as JSON-ready values (the recording's sensor metadata)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["topics"] = dict(self.topics)
        out["pose"] = list(self.pose)
        return out
