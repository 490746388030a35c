"""The controller room's mapping: a ros2_controllers plugin type -> how to build it.

A controller module registers its own types (:func:`controller_type`); the manager looks a type
up here (:func:`factory_of`) and never names a controller class. The room's modules are found
by walking the package on first use, so a new controller is one module in
``harness/controllers/`` and touches no other file.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

from harness.controllers.base import Controller, SensorInterfaces
from harness.controllers.config import ControllerSpec
from harness.controllers.errors import UnknownControllerType
from harness.rooms import Room

__all__ = [
    "NO_SENSORS",
    "Factory",
    "RobotInterfaces",
    "controller_type",
    "factory_of",
    "known_types",
]


class _NoSensors:
    """The sensor state interfaces of a robot without sensors."""

    names: tuple[str, ...] = ()

    def claim(self, names: Sequence[str]) -> None:
        pass

    def values(self) -> Mapping[str, float]:
        return {}


NO_SENSORS: SensorInterfaces = _NoSensors()


@dataclass(frozen=True)
class RobotInterfaces:
    """What a controller is built against: ``source`` (the controllers file, for messages),
    the robot's controllable joints -> control mode, every joint its ``joint_states`` hold, and
    its sensors' state interfaces (``<sensor>/<interface>``)."""

    source: str
    controllable: Mapping[str, str]
    joints: Sequence[str]
    sensors: SensorInterfaces = field(default=NO_SENSORS)


Factory = Callable[[ControllerSpec, RobotInterfaces], Controller]
"""Builds one controller; raises :class:`~harness.controllers.errors.ControllersConfigError`
when its parameters do not fit the robot."""

F = TypeVar("F", bound=Factory)

_FACTORIES: dict[str, Factory] = {}


def controller_type(*types: str) -> Callable[[F], F]:
    """Register the decorated factory for the plugin ``types`` (one module's own types)."""

    def register(factory: F) -> F:
        for name in types:
            known = _FACTORIES.get(name)
            if known is not None and _origin(known) != _origin(factory):
                raise ValueError(f"controller type {name!r} is registered twice")
            _FACTORIES[name] = factory
        return factory

    return register


def _origin(factory: Factory) -> tuple[str, str]:
    """Where ``factory`` is defined: a module imported again (a test that reloads it)
    registers the same names anew, which is not a clash."""
    return (getattr(factory, "__module__", ""), getattr(factory, "__qualname__", repr(factory)))


_discover = Room(__name__.rpartition(".")[0]).discover


def known_types() -> tuple[str, ...]:
    """Every registered controller type, sorted."""
    _discover()
    return tuple(sorted(_FACTORIES))


def factory_of(type: str) -> Factory:
    """The factory of ``type``; :class:`UnknownControllerType` (one line naming it and the
    known types) when no module registers it."""
    _discover()
    factory = _FACTORIES.get(type)
    if factory is None:
        raise UnknownControllerType(
            f"unknown controller type {type!r} (known: {', '.join(known_types())})"
        )
    return factory
