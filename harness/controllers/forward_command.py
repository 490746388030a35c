"""``forward_command_controller/ForwardCommandController`` and its named variants
(``position_controllers/JointGroupPositionController``, ``velocity_controllers/...``,
``effort_controllers/...``): ``~/commands`` (``std_msgs/msg/Float64MultiArray``), one value
per joint in the controller's ``joints`` order, written to ``interface_name``. A message of
the wrong length is refused (nothing changes), as the real controller ignores it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from harness.controllers.base import (
    Command,
    Controller,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    TopicEndpoint,
)
from harness.controllers.config import TYPE_FORWARD, ControllerSpec
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["FORWARD_TYPES", "ForwardCommandController"]

FORWARD_TYPES: Mapping[str, str | None] = {
    TYPE_FORWARD: None,
    "position_controllers/JointGroupPositionController": "position",
    "velocity_controllers/JointGroupVelocityController": "velocity",
    "effort_controllers/JointGroupEffortController": "effort",
}
"""Plugin name -> the interface it writes (None: the ``interface_name`` parameter)."""
_INTERFACES = ("position", "velocity", "effort")
_new = tuple.__new__


class ForwardCommandController(ControllerBase):
    """One forward command controller (see the module docstring)."""

    reads_state = False
    """Its methods never look at the :class:`JointReadings` they are given (the session then
    copies no joint arrays for it: a command may come every step). A subclass that reads them
    sets this True."""

    def __init__(self, spec: ControllerSpec, source: str, controllable: Mapping[str, str]) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, source)
        self.joints = p.joints(p.strings("joints"), controllable)
        fixed = FORWARD_TYPES.get(spec.type)
        self.interface = fixed if fixed is not None else p.string("interface_name")
        if self.interface not in _INTERFACES:
            raise p.error(
                f"interface_name must be one of {', '.join(_INTERFACES)}, not {self.interface!r}"
            )
        self.command_interfaces = tuple(f"{j}/{self.interface}" for j in self.joints)
        self.subscriptions = (TopicEndpoint("~/commands", "std_msgs/msg/Float64MultiArray"),)

    def commands(self, msg: Mapping[str, Any]) -> list[Command]:
        """The joint commands of one ``Float64MultiArray``; ``ValueError`` when refused (the
        simulation refuses non-finite values)."""
        data = self._data(msg)
        interface = self.interface
        # tuple.__new__: a message may come every step (the same Command, for less)
        pairs = zip(self.joints, data, strict=True)
        if interface == "position":
            return [_new(Command, (j, float(v), None, None)) for j, v in pairs]
        if interface == "velocity":
            return [_new(Command, (j, None, float(v), None)) for j, v in pairs]
        return [_new(Command, (j, None, None, float(v))) for j, v in pairs]

    def _data(self, msg: Mapping[str, Any]) -> list[Any]:
        data = list(msg["data"])
        if len(data) != len(self.joints):
            raise ValueError(
                f"expected {len(self.joints)} values (one per joint: {', '.join(self.joints)}), "
                f"got {len(data)}"
            )
        return data

    def on_message(
        self, topic: str, msg: Mapping[str, Any], connection: int, state: JointReadings
    ) -> ControllerOutput:
        """A command message: applied at once (the simulation holds it)."""
        out = ControllerOutput()
        if not self.active:
            out.logs.append(LogLine(40, "inactive, command ignored", connection))
            return out
        try:
            out.commands += self.commands(msg)
        except ValueError as exc:
            out.logs.append(LogLine(40, f"command refused: {exc}", connection))
        return out


@controller_type(*FORWARD_TYPES)
def _forward(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return ForwardCommandController(spec, robot.source, robot.controllable)
