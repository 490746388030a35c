"""The sensor room's mapping: a sensor type -> its kind record (:class:`SensorKind`).

Each sensor module registers the kinds it implements (:func:`register_kind`): the harness type
(``imu``), the Gazebo/SDF ``<sensor type>`` spellings that mean it, its outputs and default
rate, its default topics, what it reads from a ``<sensor>`` element and how it is built on a
mount, and its options record (a frozen :class:`~harness.sensors.options.SensorOptions`
dataclass of the fields only it reads, validating them). The suite and the declaration readers
look kinds up here and never name a sensor class; :class:`~harness.sensors.spec.SensorSpec`
splits a mapping's flat keys into the common fields and the kind's options record. The room's
modules are found by walking the package on first use, so **a new sensor kind is one module in
``harness/sensors/`` with its options record** (``register_kind(SensorKind(...,
options=MyOptions))``) and touches no other file.
"""

from __future__ import annotations

import builtins
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from harness.rooms import Room
from harness.sensors.errors import UnknownSensorType
from harness.sensors.options import NoOptions, SensorOptions

if TYPE_CHECKING:
    import mujoco

    from harness.sensors.render import OffscreenRenderer

__all__ = [
    "Mount",
    "Mounted",
    "SensorKind",
    "gazebo_kind",
    "kind_of",
    "known_types",
    "register_kind",
]


F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Mount:
    """A sensor frame fixed to a body: ``position``/``rotation`` in the body frame."""

    body: int
    body_name: str
    position: F64
    rotation: F64

    def world(self, data: mujoco.MjData) -> tuple[F64, F64]:
        """The sensor frame in the world: (position, rotation matrix)."""
        body_rot = data.xmat[self.body].reshape(3, 3)
        return data.xpos[self.body] + body_rot @ self.position, body_rot @ self.rotation


@dataclass(frozen=True)
class Mounted:
    """Where a sensor is built: the ``model``, its ``mount``, its resolved ``topics`` (output
    key -> topic), its ``frame_id`` (with the robot's prefix), the robot's name ``prefix`` and
    the session's shared offscreen ``renderer`` (started on first call)."""

    model: mujoco.MjModel
    mount: Mount
    topics: Mapping[str, str]
    frame_id: str
    prefix: str
    renderer: Callable[[], OffscreenRenderer]


def _no_params(element: Any, where: str) -> dict[str, Any]:
    return {}


def _own_topics(outputs: tuple[str, ...]) -> Callable[[str, str], dict[str, str]]:
    def topics(topic: str, base: str) -> dict[str, str]:
        return {outputs[0]: topic or f"{base}/{outputs[0]}"}

    return topics


@dataclass(frozen=True)
class SensorKind:
    """One sensor kind. ``type``: the harness's name (a :class:`SensorSpec`'s ``type``);
    ``gazebo``: the ``<sensor type>`` spellings of URDF/SDF files that declare it; ``outputs``:
    its output keys (the keys of ``SensorSpec.topics``), the first the main one; ``rate``: the
    default update rate (Hz of simulation time); ``build``: the sensor of a spec at a mount;
    ``topics``: ``(topic, base)`` -> every output's default topic (``topic`` the declared
    ``<topic>`` or "", ``base`` the plugin's camera name or the sensor name; relative names
    stay relative); ``params``: the spec fields a ``<sensor>`` element gives (``(element,
    where)``; noise, sizes, ...); ``renders``: it draws the scene (a camera), so a session
    loads its robot with the visual geoms; ``options``: its options record (the class; a
    spec's ``options`` is an instance), whose field names are the keys only this kind takes."""

    type: str
    outputs: tuple[str, ...]
    rate: float
    build: Callable[[Any, Mounted], Any]
    """Typed where it is defined (each kind's module: its :class:`SensorSpec` and a
    :class:`~harness.sensors.base.Sensor`): this mapping sits below the spec and the base
    module in the room, so it names neither."""
    gazebo: tuple[str, ...] = ()
    topics: Callable[[str, str], dict[str, str]] | None = None
    params: Callable[[Any, str], dict[str, Any]] = field(default=_no_params)
    renders: bool = False
    options: builtins.type[SensorOptions] = NoOptions

    def default_topics(self, topic: str, base: str) -> dict[str, str]:
        """Every output's topic (see :attr:`topics`; by default ``<base>/<output>``)."""
        make = self.topics if self.topics is not None else _own_topics(self.outputs)
        return make(topic, base)


_KINDS: dict[str, SensorKind] = {}
_GAZEBO: dict[str, SensorKind] = {}


def register_kind(kind: SensorKind) -> SensorKind:
    """Register ``kind`` (from its own module); a type or Gazebo spelling registered twice is
    a programming error."""
    if kind.type in _KINDS and _KINDS[kind.type] != kind:
        raise ValueError(f"sensor type {kind.type!r} is registered twice")
    _KINDS[kind.type] = kind
    for spelling in kind.gazebo:
        if spelling in _GAZEBO and _GAZEBO[spelling].type != kind.type:
            raise ValueError(f"Gazebo sensor type {spelling!r} is registered twice")
        _GAZEBO[spelling] = kind
    return kind


_discover = Room(__name__.rpartition(".")[0]).discover


def known_types() -> tuple[str, ...]:
    """Every registered sensor type, sorted."""
    _discover()
    return tuple(sorted(_KINDS))


def kind_of(type: str) -> SensorKind:
    """The kind of ``type``; :class:`UnknownSensorType` (one line naming it and the known
    types) when no module registers it."""
    _discover()
    kind = _KINDS.get(type) if isinstance(type, str) else None
    if kind is None:
        raise UnknownSensorType(f"unknown sensor type {type!r} (known: {', '.join(known_types())})")
    return kind


def gazebo_kind(spelling: str) -> SensorKind | None:
    """The kind a URDF/SDF ``<sensor type>`` declares, None for one no module implements
    (``gps``, ``altimeter``...: skipped, as a robot file may carry sensors the harness lacks)."""
    _discover()
    return _GAZEBO.get(spelling)
