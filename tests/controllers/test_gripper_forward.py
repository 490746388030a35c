"""Sans-I/O tests of the gripper action controller (reached_goal, stalled) and the forward
command controller."""

from __future__ import annotations

import pytest

from harness.controllers import ControllersConfigError, ControllerSpec, JointReadings
from harness.controllers.forward_command import ForwardCommandController
from harness.controllers.gripper_action import GripperActionController

MS = 1_000_000


def _state(t_ms: int, position: float, velocity: float = 0.0) -> JointReadings:
    return JointReadings(t_ms * MS, {"f": position}, {"f": velocity}, {"f": 1.5})


def _gripper(**params: object) -> GripperActionController:
    spec = ControllerSpec("hand", "position_controllers/GripperActionController",
                          {"joint": "f", **params})  # fmt: skip
    gripper = GripperActionController(spec, "test", {"f": "position"})
    gripper.activate(_state(0, 0.0))
    return gripper


def test_gripper_reaches_its_goal() -> None:
    gripper = _gripper()
    out = gripper.on_goal("~/gripper_cmd", 1, {"command": {"position": 0.03}}, _state(0, 0.0))
    assert [(c.joint, c.position) for c in out.commands] == [("f", 0.03)]
    assert not gripper.update(_state(10, 0.01, 0.1), 10 * MS).results
    (result,) = gripper.update(_state(20, 0.025, 0.1), 10 * MS).results
    assert result.status == 4
    assert result.values == {"position": 0.025, "effort": 1.5, "stalled": False,
                             "reached_goal": True}  # fmt: skip


@pytest.mark.parametrize(("allow", "status"), [(False, 6), (True, 4)])
def test_gripper_stalls_on_an_object(allow: bool, status: int) -> None:
    gripper = _gripper(allow_stalling=allow, stall_timeout=0.5)
    gripper.on_goal("~/gripper_cmd", 1, {"command": {"position": 0.0}}, _state(0, 0.04))
    assert not gripper.update(_state(100, 0.03, -0.1), 10 * MS).results  # moving
    assert not gripper.update(_state(500, 0.02, 0.0), 10 * MS).results  # blocked 0.4 s
    (result,) = gripper.update(_state(601, 0.02, 0.0), 10 * MS).results  # blocked > 0.5 s
    assert result.status == status
    assert result.values["stalled"] is True
    assert result.values["reached_goal"] is False


def test_gripper_preemption_cancels_the_old_goal() -> None:
    gripper = _gripper()
    gripper.on_goal("~/gripper_cmd", 1, {"command": {"position": 0.03}}, _state(0, 0.0))
    out = gripper.on_goal("~/gripper_cmd", 2, {"command": {"position": 0.01}}, _state(5, 0.0))
    assert [(r.goal, r.status) for r in out.results] == [(1, 5)]
    assert gripper.goal == 2


def test_forward_command_controller() -> None:
    spec = ControllerSpec("fwd", "velocity_controllers/JointGroupVelocityController",
                          {"joints": ["b", "a"]})  # fmt: skip
    fwd = ForwardCommandController(spec, "test", {"a": "velocity", "b": "velocity"})
    state = JointReadings(0, {}, {}, {})
    assert fwd.on_message("~/commands", {"data": [1.0, 2.0]}, 3, state).logs[0].text == (
        "inactive, command ignored"
    )
    fwd.activate(state)
    out = fwd.on_message("~/commands", {"data": [1.0, 2.0]}, 3, state)
    assert [(c.joint, c.velocity, c.position) for c in out.commands] == [
        ("b", 1.0, None),
        ("a", 2.0, None),
    ]
    out = fwd.on_message("~/commands", {"data": [1.0]}, 3, state)
    assert not out.commands
    assert out.logs[0].connection == 3
    assert "expected 2 values" in out.logs[0].text


def test_forward_needs_a_known_interface() -> None:
    spec = ControllerSpec("fwd", "forward_command_controller/ForwardCommandController",
                          {"joints": ["a"], "interface_name": "torque"})  # fmt: skip
    with pytest.raises(ControllersConfigError, match="interface_name must be one of"):
        ForwardCommandController(spec, "c.yaml", {"a": "position"})
