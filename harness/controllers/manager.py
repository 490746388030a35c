"""The controller manager of one robot, sans-I/O: controllers' lifecycle and the
``controller_manager`` services (``controller_manager_msgs``).

At start every controller of the configuration is loaded, configured (types the harness does
not implement stay ``unconfigured``) and activated in file order.

ros2_control's resource rule holds: one active claim per command interface. A controller whose
command interfaces an active controller already claims stays ``inactive``, as a spawner fails
to activate it. The one exemption is the harness's multiplexer (``multiplexer=``, a controller
whose ``multiplexes`` is true; the default set has it): it claims the joints, and every other
controller of its set claims the multiplexer's shared reference interfaces
(``command_mux/<joint>/<interface>``) instead, as a chained controller claims a following
controller's references, so the default set's command paths all stay active at once. Only
controllers a robot file or a YAML names (no multiplexer) obey the rule among themselves.

The services answer as ros2_control's controller manager (``controller_manager.cpp``) does,
with its messages (logged; the Humble-era ``SwitchController`` response has only ``ok``):
``switch_controller`` refuses a switch that would claim a command interface twice as a whole
("Unable to activate controller 'b' since the command interface 'j/position' is currently
claimed by another controller."), whatever the strictness; an unknown controller, a double
activation or deactivation and a broken chain fail the switch with STRICT and are skipped with
BEST_EFFORT (and 0, the manager's default strictness).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from harness.controllers.base import (
    Controller,
    ControllerOutput,
    JointReadings,
    LogLine,
    SensorInterfaces,
)
from harness.controllers.broadcaster import Unsupported
from harness.controllers.config import ControllersConfig, ControllerSpec
from harness.controllers.errors import ControllersConfigError, UnknownControllerType
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
    ``sensors``: its sensors' state interfaces (what a sensor broadcaster reads);
    ``multiplexer``: the harness's multiplexer of a set the harness made (loaded first; the
    set's other controllers command through it, see the module docstring)."""

    def __init__(
        self,
        config: ControllersConfig,
        controllable: Mapping[str, str],
        joints: Sequence[str],
        read: Callable[[], JointReadings],
        robot: str = "robot",
        sensors: SensorInterfaces = NO_SENSORS,
        multiplexer: Controller | None = None,
    ) -> None:
        self.config = config
        self.controllable = dict(controllable)
        self.joints = tuple(joints)
        self.robot = robot
        self._read = read
        self.specs = {spec.name: spec for spec in config.controllers}
        self.mux = multiplexer.name if multiplexer is not None else ""
        """The multiplexer's name ("" without one)."""
        self.built: dict[str, Controller] = {}
        """Every controller of the configuration (whether loaded or not), the multiplexer
        first (it is activated before the controllers that command through it)."""
        if multiplexer is not None:
            self.built[multiplexer.name] = multiplexer
        for spec in config.controllers:
            if spec.name in self.built:
                raise ControllersConfigError(
                    f"{config.source}: controller name {spec.name!r} is the harness's own"
                )
            self.built[spec.name] = make_controller(
                spec, config.source, controllable, joints, sensors
            )
        for controller in self.built.values():
            reads = [i for i in controller.state_interfaces if i in sensors.names]
            if reads:
                sensors.claim(reads)
        self.loaded: dict[str, LoadedController] = {}
        self.update_period_ns = round(1e9 / config.update_rate)
        self.periods_ns: dict[str, int] = {name: self._period(name) for name in self.built}
        """Each controller's update period (ns of simulation time): its own ``update_rate``
        parameter, at most the manager's (ros2_control updates a faster one at the manager's
        rate), else the manager's."""

    def _period(self, name: str) -> int:
        spec = self.specs.get(name)
        rate = spec.params.get("update_rate") if spec is not None else None
        if rate is None:
            return self.update_period_ns
        if isinstance(rate, bool) or not isinstance(rate, int | float) or not rate > 0:
            raise ControllersConfigError(
                f"{self.config.source}: {name}.update_rate must be a number > 0 (Hz), not {rate!r}"
            )
        return max(self.update_period_ns, round(1e9 / rate))

    # ----------------------------------------------------------------------------- lifecycle

    def start(self) -> ControllerOutput:
        """Load, configure and activate the configuration's controllers."""
        out = ControllerOutput()
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
            conflict = self._unavailable(name, (), ())
            if conflict:
                out.logs.append(LogLine(40, f"{conflict} (left inactive)"))
                continue
            out.extend(self._activate(entry))
        return out

    def _activate(self, entry: LoadedController) -> ControllerOutput:
        entry.state = "active"
        return entry.controller.activate(self._read())

    def _deactivate(self, entry: LoadedController) -> ControllerOutput:
        entry.state = "inactive"
        return entry.controller.deactivate(self._read())

    def routed(self, name: str) -> bool:
        """Whether controller ``name`` commands through the multiplexer."""
        return bool(self.mux) and name != self.mux

    def claims_of(self, name: str) -> tuple[str, ...]:
        """The command interfaces controller ``name`` claims when active: its own, or the
        multiplexer's reference interfaces of them."""
        interfaces = tuple(self.built[name].command_interfaces)
        if self.routed(name):
            return tuple(f"{self.mux}/{i}" for i in interfaces)
        return interfaces

    def _chained(self, name: str) -> bool:
        """Whether ``name`` commands joints through the multiplexer (a broadcaster does not)."""
        return self.routed(name) and bool(self.built[name].command_interfaces)

    def _shared(self, interface: str) -> bool:
        """The multiplexer's reference interfaces: claimed by any number of controllers."""
        return bool(self.mux) and interface.startswith(self.mux + "/")

    def claimed(self) -> dict[str, str]:
        """Command interface -> the active controller claiming it."""
        return {
            iface: name
            for name, entry in self.loaded.items()
            if entry.state == "active"
            for iface in self.claims_of(name)
        }

    def _unavailable(self, name: str, leaving: Sequence[str], coming: Sequence[str]) -> str:
        """Why ``name`` cannot be activated (ros2_control's message), given the controllers
        ``leaving`` and those ``coming`` before it in the same switch; "" when it can."""
        if not self.config.exclusive and not self.mux:
            return ""  # a default set without its multiplexer (a manager built alone)
        claimed = self.claimed()
        soon = {i for other in coming for i in self.claims_of(other)}
        for iface in self.claims_of(name):
            if self._shared(iface):
                continue
            owner = claimed.get(iface)
            if owner is not None and owner != name and owner not in leaving:
                return (
                    f"Unable to activate controller '{name}' since the command interface "
                    f"'{iface}' is currently claimed by another controller."
                )
            if iface in soon:
                return (
                    f"Unable to activate controller '{name}' since the command interface "
                    f"'{iface}' will be used by another controller that is being activated."
                )
        return ""

    def active(self) -> list[Controller]:
        """The active controllers, in load order."""
        return [e.controller for e in self.loaded.values() if e.state == "active"]

    def restart(self) -> ControllerOutput:
        """Deactivate and reactivate every active controller (after a reset)."""
        out = ControllerOutput()
        for entry in self.loaded.values():
            if entry.state == "active":
                out.extend(self._deactivate(entry))
                out.extend(self._activate(entry))
        return out

    # ----------------------------------------------------------------------------- services

    def handle(
        self, service: str, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        """Answer ``controller_manager/<service>``: the response values and what the change
        produced (an aborted goal, ...)."""
        handler = getattr(self, f"_srv_{service}")
        result: tuple[dict[str, Any], ControllerOutput] = handler(request)
        return result

    def _srv_list_controllers(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        controllers = []
        claimed = self.claimed()
        for name, entry in self.loaded.items():
            c = entry.controller
            claims = list(self.claims_of(name))
            references = list(getattr(c, "reference_interfaces", ()))
            chained = [i for i in claims if self._shared(i)]
            controllers.append(
                {
                    "name": name,
                    "state": entry.state,
                    "type": c.type,
                    "claimed_interfaces": claims if entry.state == "active" else [],
                    "required_command_interfaces": claims,
                    "required_state_interfaces": list(c.state_interfaces),
                    "is_chainable": bool(references),
                    "is_chained": any(i in claimed for i in references),
                    "reference_interfaces": references,
                    "chain_connections": [{"name": self.mux, "reference_interfaces": chained}]
                    if chained
                    else [],
                }
            )
        return {"controller": controllers}, ControllerOutput()

    def _srv_list_controller_types(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        types = list(known_types())
        return {"types": types, "base_classes": [_BASE_CLASS] * len(types)}, ControllerOutput()

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
    ) -> tuple[dict[str, Any], ControllerOutput]:
        command, state = self._interfaces()
        return {"command_interfaces": command, "state_interfaces": state}, ControllerOutput()

    def _srv_list_hardware_components(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        command, state = self._interfaces()
        component = {
            "name": self.robot,
            "type": "system",
            "class_type": "harness/MujocoSystem",
            "state": {"id": 3, "label": "active"},
            "command_interfaces": command,
            "state_interfaces": state,
        }
        return {"component": [component]}, ControllerOutput()

    def _srv_load_controller(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        name = str(request["name"])
        out = ControllerOutput()
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
    ) -> tuple[dict[str, Any], ControllerOutput]:
        name = str(request["name"])
        out = ControllerOutput()
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

    def _srv_unload_controller(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        name = str(request["name"])
        out = ControllerOutput()
        entry = self.loaded.get(name)
        if entry is None or entry.state == "active":
            why = "is not loaded" if entry is None else "is active (deactivate it first)"
            out.logs.append(LogLine(40, f"unload_controller: {name!r} {why}"))
            return {"ok": False}, out
        del self.loaded[name]
        return {"ok": True}, out

    def _srv_switch_controller(
        self, request: Mapping[str, Any]
    ) -> tuple[dict[str, Any], ControllerOutput]:
        """ros2_control's ``switch_controller_cb``, in its order and with its messages."""
        activate = [*request.get("activate_controllers", ()), *request.get("start_controllers", ())]
        deactivate = [
            *request.get("deactivate_controllers", ()),
            *request.get("stop_controllers", ()),
        ]
        strict = int(request.get("strictness", 0)) == STRICT
        out = ControllerOutput()

        def refuse(text: str) -> tuple[dict[str, Any], ControllerOutput]:
            out.logs.append(LogLine(40, f"switch_controller: {text}"))
            return {"ok": False}, out

        def problem(text: str) -> bool:
            """STRICT: the switch fails; BEST_EFFORT: the controller is skipped."""
            if strict:
                refuse(text)
                out.logs.append(
                    LogLine(40, "switch_controller: Aborting, no controller is switched! "
                            "('STRICT' switch)")
                )  # fmt: skip
                return True
            out.logs.append(LogLine(30, f"switch_controller: {text}"))
            return False

        to_stop: list[str] = []
        to_start: list[str] = []
        for action, names, into in (
            ("deactivate", deactivate, to_stop),
            ("activate", activate, to_start),
        ):
            for name in names:
                if name in self.loaded:
                    into.append(name)
                elif problem(
                    f"Could not {action} controller with name '{name}' because no controller "
                    "with this name exists"
                ):
                    return {"ok": False}, out
        for name in list(to_stop):
            if self.loaded[name].state != "active":
                if problem(f"Could not deactivate controller '{name}' since it is not active"):
                    return {"ok": False}, out
                to_stop.remove(name)
        for name in list(to_start):
            state = self.loaded[name].state
            if state == "active" and name not in to_stop:
                if problem(f"Could not activate controller '{name}' since it is already active"):
                    return {"ok": False}, out
                to_start.remove(name)
            elif state == "unconfigured":
                if problem(
                    f"Could not activate controller '{name}' since it is not in inactive state"
                ):
                    return {"ok": False}, out
                to_start.remove(name)
        if self.mux:  # the chain: the multiplexer follows every other controller of its set
            mux = self.mux
            mux_on = (self.loaded[mux].state == "active" and mux not in to_stop) or (
                mux in to_start
            )
            for name in list(to_start):
                if self._chained(name) and not mux_on:
                    if problem(
                        f"The following controller with name '{mux}' is currently inactive "
                        "and it is not requested to be activated."
                    ):
                        return {"ok": False}, out
                    to_start.remove(name)
            if mux in to_stop and mux not in to_start:
                for name, entry in self.loaded.items():
                    staying = entry.state == "active" and name not in to_stop
                    if self._chained(name) and (staying or name in to_start):
                        if problem(
                            f"Unable to deactivate controller with name '{mux}' because "
                            f"preceding controller with name '{name}' is currently active and "
                            "will not be deactivated."
                        ):
                            return {"ok": False}, out
                        to_stop.remove(mux)
                        break
        if not to_start and not to_stop:
            return {"ok": True}, out
        coming: list[str] = []
        for name in to_start:
            if name in to_stop:
                continue  # restarted: its interfaces stay its own
            conflict = self._unavailable(name, to_stop, coming)
            if conflict:  # ros2_control refuses the whole switch, whatever the strictness
                return refuse(conflict)
            coming.append(name)
        to_stop.sort(key=lambda n: n == self.mux)  # the multiplexer after its controllers
        to_start.sort(key=lambda n: n != self.mux)  # and before them
        for name in to_stop:
            out.extend(self._deactivate(self.loaded[name]))
        for name in to_start:
            out.extend(self._activate(self.loaded[name]))
        return {"ok": True}, out
