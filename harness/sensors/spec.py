"""One sensor's declaration (:class:`SensorSpec`), whatever file or list it came from.

The same keys are spelled the same in a scenario's ``sensors:`` list, the ``sensors=`` option of
:class:`harness.Session` and the recording's sensor metadata (:meth:`SensorSpec.to_json`). The
keys every sensor has are the spec's fields; the keys only one kind takes (a camera's
``width``, a lidar's ``samples``) are its options record (:attr:`SensorSpec.options`, the
class its module registers, :attr:`harness.sensors.registry.SensorKind.options`): a mapping's
flat keys are split by the kind (:meth:`SensorSpec.make`), and a key of another kind is refused
in one line.
"""

from __future__ import annotations

import builtins
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, TypeVar

from harness.sensors.errors import SensorConfigError, UnknownSensorType
from harness.sensors.options import NoOptions, SensorOptions, check_finite, check_positive
from harness.sensors.registry import SensorKind, kind_of, known_types

__all__ = ["SensorSpec", "SensorType", "sensor_token"]

SensorType = str
"""A sensor type: one a module of the sensors room registers (:mod:`harness.sensors.registry`)."""

_O = TypeVar("_O", bound=SensorOptions)

_V1_KEYS = (
    "name", "type", "parent", "pose", "joint", "camera", "site", "update_rate", "topic",
    "topics", "frame_id", "width", "height", "hfov", "near", "far", "record", "samples",
    "min_angle", "max_angle", "vertical_samples", "vertical_min_angle", "vertical_max_angle",
    "range_min", "range_max", "range_resolution", "noise_mean", "noise_stddev",
    "accel_noise_mean", "accel_noise_stddev", "ft_frame", "ft_direction", "collision",
    "namespace", "source",
)  # fmt: skip
"""The keys of the recorded sensor metadata, format v1 (:meth:`SensorSpec.to_json`), in order."""
_V1_KEY_SET = frozenset(_V1_KEYS)

_V1_OPTION_DEFAULTS: Mapping[str, Any] = MappingProxyType(
    {
        "width": 320, "height": 240, "hfov": 1.047, "near": 0.05, "far": 100.0, "record": "raw",
        "samples": 360, "min_angle": -math.pi, "max_angle": math.pi, "vertical_samples": 1,
        "vertical_min_angle": 0.0, "vertical_max_angle": 0.0, "range_min": 0.1,
        "range_max": 30.0, "range_resolution": 0.0, "accel_noise_mean": None,
        "accel_noise_stddev": None, "ft_frame": "child", "ft_direction": "child_to_parent",
        "collision": "",
    }
)  # fmt: skip
"""Format v1 records every kind's options: a kind's record gives its own, the others are
written with these values (the flat record's defaults when v1 was fixed). Frozen here on
purpose: a kind changing a default must not change recorded bytes."""

_UNSET = NoOptions()
"""The ``options`` default: the kind's record with its defaults."""


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
    (z forward, x right, y down). Noise: Gaussian ``noise_mean``/``noise_stddev`` (ranges and
    depth in m; IMU on each angular velocity (rad/s) and linear acceleration (m/s^2) axis;
    force-torque on each axis), drawn from the session seed. ``namespace``: the robot's (set
    by the loader). ``options``: the kind's own record (default: its defaults), e.g.
    :class:`~harness.sensors.camera.CameraOptions` (``width``, ``height``, ``hfov``,
    ``near``/``far``, ``record``), :class:`~harness.sensors.lidar.LidarOptions` (``samples``,
    angles, ranges), :class:`~harness.sensors.imu.ImuOptions` (``accel_noise_*``),
    :class:`~harness.sensors.force_torque.ForceTorqueOptions` (``ft_frame``,
    ``ft_direction``), :class:`~harness.sensors.contact.ContactOptions` (``collision``); read
    it typed with :meth:`options_as`. Build a spec from flat keys with :meth:`make`.

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
    noise_mean: float = 0.0
    noise_stddev: float = 0.0
    namespace: str = ""
    source: str = ""
    """Where it was declared (a file name, ``scenario``), for error messages."""
    options: SensorOptions = _UNSET
    """The kind's options record (an instance of its :attr:`SensorKind.options`)."""

    @property
    def where(self) -> str:
        """``sensor 'name' (source)``: how error messages name this sensor."""
        return _where(self.name, self.source)

    def __post_init__(self) -> None:
        where = self.where
        if not isinstance(self.name, str) or not self.name.strip():
            raise SensorConfigError(f"{where}: the name must be non-empty text")
        if any(not c.isprintable() for c in self.name):
            raise SensorConfigError(f"{where}: the name must not hold a control character")
        kind = _kind(self.type, where)
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
        try:
            check_positive("update_rate", self.update_rate, zero=True)
            check_positive("noise_stddev", self.noise_stddev, zero=True)
            check_finite("noise_mean", self.noise_mean)
        except SensorConfigError as exc:
            raise SensorConfigError(f"{where}: {exc}") from None
        if self.options is _UNSET:
            object.__setattr__(self, "options", kind.options())
        elif type(self.options) is not kind.options:
            raise SensorConfigError(
                f"{where}: a {self.type} sensor's options are a {kind.options.__name__}, "
                f"not a {type(self.options).__name__}"
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

    @property
    def token(self) -> str:
        """The name as it appears in default topics and frames (:func:`sensor_token`)."""
        return sensor_token(self.name)

    @property
    def period_hz(self) -> float:
        """The update rate (never None after validation)."""
        assert self.update_rate is not None
        return float(self.update_rate)

    def options_as(self, cls: builtins.type[_O]) -> _O:
        """The options record typed as ``cls`` (its kind's; a kind module reads its own
        sensors' options so). Another class is a programming error."""
        if not isinstance(self.options, cls):
            raise TypeError(
                f"{self.where}: options are a {type(self.options).__name__}, not {cls.__name__}"
            )
        return self.options

    @classmethod
    def make(cls, **keys: Any) -> SensorSpec:
        """A spec from flat keys (as a scenario writes them): the common fields go to the
        spec, the rest to its kind's options record. A key of another kind, or of none, is
        one :class:`SensorConfigError` naming it and what this kind takes."""
        name, type_ = keys.get("name", ""), keys.get("type", "")
        where = _where(name, str(keys.get("source", "")))
        kind = _kind(type_, where)
        fields: dict[str, Any] = {}
        given: dict[str, Any] = {}
        own = kind.options.names()
        for key, value in keys.items():
            if key in _COMMON:
                fields[key] = value
            elif key in own:
                given[key] = value
            elif key in _all_options():
                listed = ", ".join(own) if own else "none"
                raise SensorConfigError(
                    f"{where}: {key!r} is not an option of a {type_} sensor (its options: {listed})"
                )
            else:
                raise SensorConfigError(
                    f"{where}: unknown sensor key {key!r} (known: {', '.join(_known_keys())})"
                )
        try:
            options = kind.options(**given)
        except SensorConfigError as exc:
            raise SensorConfigError(f"{where}: {exc}") from None
        return cls(**fields, options=options)

    @classmethod
    def from_mapping(cls, value: object, where: str = "sensors") -> SensorSpec:
        """A spec from a scenario/Python mapping (keys as the fields and the kind's options;
        ``pose`` a list of 6). A whole recorded record (:meth:`to_json`: every v1 key, other
        kinds' options included, as ``Session(sensors=[spec])`` passes a spec on) is read as
        :meth:`from_json` reads it."""
        if isinstance(value, SensorSpec):
            return value
        if not isinstance(value, Mapping):
            raise SensorConfigError(f"{where}: a sensor must be a mapping, not {value!r}")
        if value.keys() >= _V1_KEY_SET:
            return cls.from_json(value, where)
        return cls._from_keys(value, where)

    @classmethod
    def _from_keys(cls, value: Mapping[Any, Any], where: str) -> SensorSpec:
        known = _known_keys()
        unknown = sorted(str(k) for k in value if k not in known)
        if unknown:
            raise SensorConfigError(
                f"{where}: unknown sensor key {unknown[0]!r} (known: {', '.join(known)})"
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
            return cls.make(**kwargs)
        except TypeError as exc:
            raise SensorConfigError(f"{where}: sensor {value['name']!r}: {exc}") from None

    @classmethod
    def from_json(cls, value: Mapping[str, Any], where: str = "recording") -> SensorSpec:
        """A spec from recorded sensor metadata (:meth:`to_json`, format v1, which holds every
        kind's option keys: those of other kinds are dropped)."""
        if not isinstance(value, Mapping):
            raise SensorConfigError(f"{where}: a sensor must be a mapping, not {value!r}")
        type_ = value.get("type")
        own = set(_kind(type_, _where(value.get("name"), where)).options.names())
        foreign = _all_options() - own
        return cls._from_keys({k: v for k, v in value.items() if k not in foreign}, where)

    def to_json(self) -> dict[str, Any]:
        """Every field as JSON-ready values: the recording's sensor metadata.

        This is the recorded format v1 (the flat record's): the keys of :data:`_V1_KEYS` in
        that order, every kind's option keys included, another kind's at its v1 default
        (:data:`_V1_OPTION_DEFAULTS`); recorded bytes depend on it, so keep it so. Options of
        a kind v1 did not know follow, in their record's order."""
        own = {n: getattr(self.options, n) for n in self.options.names()}
        values: dict[str, Any] = {f: getattr(self, f) for f in _COMMON}
        values["topics"] = dict(self.topics)
        values["pose"] = list(self.pose)
        values.update(_V1_OPTION_DEFAULTS)
        values.update(own)
        out = {key: values[key] for key in _V1_KEYS}
        out.update((k, v) for k, v in own.items() if k not in out)
        return out


_COMMON = frozenset(f.name for f in dataclasses.fields(SensorSpec) if f.name != "options")
"""The keys every sensor takes (the spec's own fields)."""


def _where(name: object, source: str) -> str:
    return f"sensor {name!r}" + (f" ({source})" if source else "")


def _kind(type_: object, where: str) -> SensorKind:
    try:
        return kind_of(type_)  # type: ignore[arg-type]
    except UnknownSensorType:
        raise UnknownSensorType(
            f"{where}: type {type_!r} is not one of {', '.join(known_types())}"
        ) from None


def _all_options() -> frozenset[str]:
    """Every registered kind's option names."""
    return frozenset(n for t in known_types() for n in kind_of(t).options.names())


def _known_keys() -> tuple[str, ...]:
    """Every key a sensor mapping may give (for one kind or another), sorted."""
    return tuple(sorted(_COMMON | _all_options()))
