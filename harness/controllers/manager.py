"""The controller manager of one robot, sans-I/O: controllers' lifecycle and the
``controller_manager`` services (``controller_manager_msgs``).

At start every controller of the configuration is loaded, configured (types the harness does
not implement stay ``unconfigured``) and activated in file order; with ``exclusive`` (every
YAML configuration) a controller whose command interfaces an active controller already claims
stays ``inactive``, as a spawner would fail to activate it. The services answer as
ros2_control's controller manager does: ``switch_controller`` with STRICT fails as a whole on an
unknown, unconfigured or conflicting controller, BEST_EFFORT (and 0) skips it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from harness.controllers.base import Controller, JointReadings, LogLine, Output, SensorInterfaces
from harness.controllers.broadcaster import Unsupported
from harness.controllers.config import ControllersConfig, ControllerSpec
from harness.controllers.errors import UnknownControllerType
from harness.controllers.registry import NO_SENSORS, RobotInterfaces, factory_of, known_types

__all__ = ["SERVICES", "ControllerManager", "LoadedController", "make_controller"]

STRICT = 2
BEST_EFFORT = 1
_MODE_INTERFACE = {"kinematic": "position", "position": "position"}
_BASE_CLASS = "controller_interface::ControllerInterface"

SERVICES: Mapping[str, str] = {
    "list_controllers": "controller_manager_msgs/srv/ListControllers",
    "list_controller_types": "controller_manager_msgs/srv/ListControllerTypes",
    "list_hardware_interfaces": "controller_manager_msgs/srv/ListHardwareInterfaces",
    "list_hardware_components": "controller_manager_msgs/srv/ListHardwareComponents",
    "switch_controller": "controller_manager_msgs/srv/SwitchController",
    "load_controller": "controller_manager_msgs/srv/LoadController",
    "configure_controller": "controller_manager_msgs/srv/ConfigureController",
    "unload_controller": "controller_manager_msgs/srv/UnloadController",
}
"""``controller_manager/<service>`` -> service type."""


def make_controller(
    spec: ControllerSpec,
    source: str,
    controllable: Mapping[str, str],
    joints: Sequence[str],
    sensors: SensorInterfaces = NO_SENSORS,
) -> Controller:
    """The controller of ``spec``, built by the factory its type registers
    (:mod:`harness.controllers.registry`); :class:`Unsupported` for a type no module registers
    (its reason names the type and the known ones);
    :class:`~harness.controllers.errors.ControllersConfigError` when its parameters do not fit
    the robot."""
    try:
        factory = factory_of(spec.type)
    except UnknownControllerType as exc:
        return Unsupported(spec, str(exc))
    return factory(spec, RobotInterfaces(source, controllable, tuple(joints), sensors))


@dataclass
class LoadedController:
    """A loaded controller and its lifecycle state."""

    controller: Controller
    state: str  # unconfigured | inactive | active

    @property
    def supported(self) -> bool:
        """Whether the harness implements its type."""
        return not isinstance(self.controller, Unsupported)


class ControllerManager:
    """The controllers of one robot. ``controllable``: its controllable joints -> control mode;
    ``joints``: every joint its ``joint_states`` hold; ``read``: the joints' state now;
    ``sensors``: its sensors' state interfaces (what a sensor broadcaster reads)."""

    def __init__(
        self,
        config: ControllersConfig,
        controllable: Mapping[str, str],
        joints: Sequence[str],
        read: Callable[[], JointReadings],
        robot: str = "robot",
        sensors: SensorInterfaces = NO_SENSORS,
    ) -> None:
        self.config = config
        self.controllable = dict(controllable)
        self.joints = tuple(joints)
        self.robot = robot
        self._read = read
        self.specs = {spec.name: spec for spec in config.controllers}
        self.built: dict[str, Controller] = {
            spec.name: make_controller(spec, config.source, controllable, joints, sensors)
            for spec in config.controllers
        }
        """Every controller of the configuration (whether loaded or not)."""
        for controller in self.built.values():
            reads = [i for i in controller.state_interfaces if i in sensors.names]
            if reads:
                sensors.claim(reads)
        self.loaded: dict[str, LoadedController] = {}
        self.update_period_ns = round(1e9 / config.update_rate)

    # ----------------------------------------------------------------------------- lifecycle

    def start(self) -> Output:
        """Load, configure and activate the configuration's controllers."""
        out = Output()
        for name, controller in self.built.items():
            entry = LoadedController(controller, "unconfigured")
            self.loaded[name] = entry
            if isinstance(controller, Unsupported):
                out.logs.append(
                    LogLine(
                        30, f"controller {name!r}: {controller.reason}: loaded, left unconfigured"
                    )
                )
                continue
            entry.state = "inactive"
            conflict = self._conflict(controller, ())
            if conflict:
                out.logs.append(LogLine(30, f"controller {name!r} left inactive: {conflict}"))
                continue
            out.extend(self._activate(entry))
        return out

    def _activate(self, entry: LoadedController) -> Output:
        entry.state = "active"
        return entry.controller.activate(self._read())

    def _deactivate(self, entry: LoadedController) -> Output:
        entry.state = "inactive"
        return entry.controller.deactivate(self._read())

    def claimed(self) -> dict[str, str]:
        """Command interface -> the active controller claiming it."""
        return {
            iface: name
            for name, entry in self.loaded.items()
            if entry.state == "active"
            for iface in entry.controller.command_interfaces
        }

    def _conflict(self, controller: Controller, leaving: Sequence[str]) -> str:
        if not self.config.exclusive:
            return ""
        for iface, owner in self.claimed().items():
            if (
                owner not in leaving
                and owner != controller.name
                and (iface in controller.command_interfaces)
            ):
                return f"{iface} is claimed by active controller {owner!r}"
        return ""

    def active(self) -> list[Controller]:
        """The active controllers, in load order."""
        return [e.controller for e in self.loaded.values() if e.state == "active"]

    def restart(self) -> Output:
        """Deactivate and reactivate every active controller (after a reset)."""
        out = Output()
        for entry in self.loaded.values():
            if entry.state == "active":
                out.extend(self._deactivate(entry))
                out.extend(self._activate(entry))
        return out

    # ----------------------------------------------------------------------------- services

    def handle(self, service: str, request: Mapping[str, Any]) -> tuple[dict[str, Any], Output]:
        """Answer ``controller_manager/<service>``: the response values and what the change
        produced (an aborted goal, ...)."""
        handler = getattr(self, f"_srv_{service}")
        result: tuple[dict[str, Any], Output] = handler(request)
        return result

    def _srv_list_controllers(self, request: Mapping[str, Any]) -> tuple[dict[str, Any], Output]:
        controllers = []
        for name, entry in self.loaded.items():
            c = entry.controller
            controllers.append(
                {
                    "name": name,
                    "state": entry.state,
                    "type": c.type,
                    "claimed_interfaces": list(c.command_interfaces)
                    if entry.state == "active"
                    else [],
                    "required_command_interfaces": list(c.command_interfaces),
                    "required_state_interfaces": list(c.state_interfaces),
                    "is_chainable": False,
                    "is_chained": False,
                    "reference_interfaces": [],
                    "chain_connections": [],
                }
            )
        return {"controller": controllers}, Output()

    def _srv_list_controller_types(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], Output]:
        types = list(known_types())
        return {"types": types, "base_classes": [_BASE_CLASS] * len(types)}, Output()

    def _interfaces(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        claimed = self.claimed()
        command = [
            {
                "name": f"{j}/{_MODE_INTERFACE.get(mode, mode)}",
                "is_available": True,
                "is_claimed": f"{j}/{_MODE_INTERFACE.get(mode, mode)}" in claimed,
            }
            for j, mode in self.controllable.items()
        ]
        state = [
            {"name": f"{j}/{i}", "is_available": True, "is_claimed": False}
            for j in self.joints
            for i in ("position", "velocity", "effort")
        ]
        return command, state

    def _srv_list_hardware_interfaces(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], Output]:
        command, state = self._interfaces()
        return {"command_interfaces": command, "state_interfaces": state}, Output()

    def _srv_list_hardware_components(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], Output]:
        command, state = self._interfaces()
        component = {
            "name": self.robot,
            "type": "system",
            "class_type": "harness/MujocoSystem",
            "state": {"id": 3, "label": "active"},
            "command_interfaces": command,
            "state_interfaces": state,
        }
        return {"component": [component]}, Output()

    def _srv_load_controller(self, request: Mapping[str, Any]) -> tuple[dict[str, Any], Output]:
        name = str(request["name"])
        out = Output()
        if name in self.loaded:
            out.logs.append(LogLine(40, f"load_controller: {name!r} is already loaded"))
            return {"ok": False}, out
        if name not in self.built:
            out.logs.append(
                LogLine(40, f"load_controller: {name!r} has no type in the controllers config")
            )
            return {"ok": False}, out
        self.loaded[name] = LoadedController(self.built[name], "unconfigured")
        return {"ok": True}, out

    def _srv_configure_controller(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], Output]:
        name = str(request["name"])
        out = Output()
        entry = self.loaded.get(name)
        if entry is None or not entry.supported or entry.state == "active":
            why = (
                "is not loaded"
                if entry is None
                else "is active (deactivate it first)"
                if entry.state == "active"
                else f"has type {entry.controller.type}, which the harness does not implement"
            )
            out.logs.append(LogLine(40, f"configure_controller: {name!r} {why}"))
            return {"ok": False}, out
        entry.state = "inactive"
        return {"ok": True}, out

    def _srv_unload_controller(self, request: Mapping[str, Any]) -> tuple[dict[str, Any], Output]:
        name = str(request["name"])
        out = Output()
        entry = self.loaded.get(name)
        if entry is None or entry.state == "active":
            why = "is not loaded" if entry is None else "is active (deactivate it first)"
            out.logs.append(LogLine(40, f"unload_controller: {name!r} {why}"))
            return {"ok": False}, out
        del self.loaded[name]
        return {"ok": True}, out

    def _srv_switch_controller(self, request: Mapping[str, Any]) -> tuple[dict[str, Any], Output]:
        activate = [*request.get("activate_controllers", ()), *request.get("start_controllers", ())]
        deactivate = [
            *request.get("deactivate_controllers", ()),
            *request.get("stop_controllers", ()),
        ]
        strict = int(request.get("strictness", 0)) == STRICT
        out = Output()
        problems: list[str] = []
        to_stop: list[str] = []
        for name in deactivate:
            entry = self.loaded.get(name)
            if entry is None:
                problems.append(f"{name!r} is not loaded")
            elif entry.state != "active":
                problems.append(f"{name!r} is not active")
            else:
                to_stop.append(name)
        to_start: list[str] = []
        for name in activate:
            entry = self.loaded.get(name)
            if entry is None:
                problems.append(f"{name!r} is not loaded")
            elif entry.state == "active" and name not in to_stop:
                problems.append(f"{name!r} is already active")
            elif entry.state == "unconfigured":
                problems.append(f"{name!r} is not configured")
            else:
                conflict = self._conflict(entry.controller, to_stop)
                claimed_here = {
                    i for n in to_start for i in self.loaded[n].controller.command_interfaces
                }
                if (
                    not conflict
                    and self.config.exclusive
                    and claimed_here.intersection(entry.controller.command_interfaces)
                ):
                    conflict = "another controller being activated claims the same interfaces"
                if conflict:
                    problems.append(f"{name!r}: {conflict}")
                else:
                    to_start.append(name)
        for problem in problems:
            out.logs.append(LogLine(40, f"switch_controller: {problem}"))
        if strict and problems:
            return {"ok": False}, out
        for name in to_stop:
            out.extend(self._deactivate(self.loaded[name]))
        for name in to_start:
            out.extend(self._activate(self.loaded[name]))
        return {"ok": True}, out
