"""The controllers room: types map to factories registered by their own modules; an unknown
type is one line naming it and the known ones; a plug-in controller needs no core edit."""

from __future__ import annotations

import pytest

from harness.controllers import (
    Controller,
    ControllerBase,
    ControllerManager,
    ControllerOutput,
    ControllerSpec,
    JointReadings,
    RobotInterfaces,
    UnknownControllerType,
    controller_type,
    known_types,
    load_controllers,
)
from harness.controllers import registry as controllers_registry

UNKNOWN = "controller_manager:\n  ros__parameters:\n    io:\n      type: vendor/IOController\n"


def _state() -> JointReadings:
    zero = {"a": 0.0}
    return JointReadings(0, zero, zero, zero)


def test_an_unknown_controller_type_is_one_line_naming_it_and_the_known_ones() -> None:
    manager = ControllerManager(load_controllers(UNKNOWN), {"a": "position"}, ["a"], _state)
    (line,) = [log.text for log in manager.start().logs]
    assert "\n" not in line
    assert line.startswith(
        "controller 'io': unknown controller type 'vendor/IOController' (known: "
    )
    known = known_types()
    assert "joint_trajectory_controller/JointTrajectoryController" in known
    assert "imu_sensor_broadcaster/IMUSensorBroadcaster" in known
    assert all(name in line for name in known)
    # still loaded and listed, never configured (a robot's YAML with a vendor's controller
    # configures the session)
    listed = manager.handle("list_controllers", {})[0]["controller"]
    assert [(c["name"], c["state"]) for c in listed] == [("io", "unconfigured")]
    with pytest.raises(UnknownControllerType, match=r"^unknown controller type 'nope/X' \(known"):
        controllers_registry.factory_of("nope/X")


@pytest.fixture
def private_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Registrations made in the test are dropped after it."""
    known_types()  # every module of the room registered first
    monkeypatch.setattr(controllers_registry, "_FACTORIES", dict(controllers_registry._FACTORIES))


class _Blinker(ControllerBase):
    """A controller from outside the room: publishes a counter; the base does the rest."""

    def __init__(self, spec: ControllerSpec) -> None:
        super().__init__(spec.name, spec.type)
        self.count = 0

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        self.count += 1
        return ControllerOutput()


@pytest.mark.usefixtures("private_registry")
def test_a_registered_type_is_built_listed_and_driven_without_a_core_edit() -> None:
    @controller_type("blink_controller/Blinker")
    def _blinker(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
        return _Blinker(spec)

    yaml = UNKNOWN.replace("vendor/IOController", "blink_controller/Blinker")
    manager = ControllerManager(load_controllers(yaml), {"a": "position"}, ["a"], _state)
    assert manager.start().logs == []
    (active,) = manager.active()
    assert isinstance(active, _Blinker)
    active.update(_state(), 10)
    assert active.count == 1
    types = manager.handle("list_controller_types", {})[0]["types"]
    assert "blink_controller/Blinker" in types
    # the base's no-op defaults
    assert active.on_goal("~/x", 1, {}, _state()) == ControllerOutput()
    assert active.command_interfaces == ()
    assert active.subscriptions == ()
    with pytest.raises(ValueError, match="registered twice"):
        controller_type("blink_controller/Blinker")(lambda spec, robot: _Blinker(spec))
