"""``position_controllers/GripperActionController``: the ``~/gripper_cmd`` action
(``control_msgs/action/GripperCommand``) on one joint.

As ros2_controllers' gripper_action_controller: a goal sets the joint's position command
(preempting the active goal, which ends canceled); every update checks it: within
``goal_tolerance`` (default 0.01) of the command the goal succeeds with ``reached_goal``; a
joint slower than ``stall_velocity_threshold`` (default 0.001) for ``stall_timeout`` (default
1.0 s) has ``stalled`` and the goal aborts (succeeds when ``allow_stalling``). A cancel holds
the current position. ``max_effort`` of a goal is not applied (a position controller).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from harness.controllers.base import (
    GOAL_ABORTED,
    GOAL_CANCELED,
    GOAL_SUCCEEDED,
    NOTHING,
    ActionEndpoint,
    Command,
    Controller,
    ControllerBase,
    ControllerOutput,
    JointReadings,
    LogLine,
    Result,
)
from harness.controllers.config import TYPE_GRIPPER, ControllerSpec
from harness.controllers.params import Params
from harness.controllers.registry import RobotInterfaces, controller_type

__all__ = ["ACTION_TYPE", "GRIPPER_TYPES", "GripperActionController"]

ACTION_TYPE = "control_msgs/action/GripperCommand"
GRIPPER_TYPES = (
    TYPE_GRIPPER,
    "effort_controllers/GripperActionController",
    "gripper_action_controller/GripperActionController",
)
"""Plugin names served by :class:`GripperActionController`."""


class GripperActionController(ControllerBase):
    """One gripper action controller (see the module docstring)."""

    def __init__(self, spec: ControllerSpec, source: str, controllable: Mapping[str, str]) -> None:
        super().__init__(spec.name, spec.type)
        p = Params(spec, source)
        (self.joint,) = p.joints([p.string("joint")], controllable)
        self.goal_tolerance = p.number("goal_tolerance", 0.01, minimum=0.0)
        self.stall_velocity = p.number("stall_velocity_threshold", 0.001)
        self.stall_timeout_ns = round(p.number("stall_timeout", 1.0, minimum=0.0) * 1e9)
        self.allow_stalling = p.flag("allow_stalling", False)
        self.command_interfaces = (f"{self.joint}/position",)
        self.state_interfaces = (f"{self.joint}/position", f"{self.joint}/velocity")
        self.actions = (ActionEndpoint("~/gripper_cmd", ACTION_TYPE),)
        self.goal: int | None = None
        self.target = 0.0
        self._last_movement = 0

    def activate(self, state: JointReadings) -> ControllerOutput:
        """Hold the current position."""
        self.active = True
        self.target = state.position[self.joint]
        return ControllerOutput()

    def deactivate(self, state: JointReadings) -> ControllerOutput:
        """Stop; an active goal ends canceled."""
        out = ControllerOutput()
        if self.goal is not None:
            out.results.append(Result(self.goal, self._values(state, False, False), GOAL_CANCELED))
            self.goal = None
        self.active = False
        return out

    def _values(self, state: JointReadings, stalled: bool, reached: bool) -> dict[str, Any]:
        return {
            "position": state.position[self.joint],
            "effort": state.effort[self.joint],
            "stalled": stalled,
            "reached_goal": reached,
        }

    def on_goal(
        self, action: str, goal: int, values: Mapping[str, Any], state: JointReadings
    ) -> ControllerOutput:
        """A GripperCommand goal: preempts the active goal, sets the position command."""
        out = ControllerOutput()
        position = float(values["command"]["position"])
        if not self.active or not math.isfinite(position):
            why = "controller is not active" if not self.active else f"position is {position!r}"
            out.results.append(Result(goal, self._values(state, False, False), GOAL_ABORTED))
            out.logs.append(LogLine(30, f"goal refused: {why}"))
            return out
        if self.goal is not None:
            out.results.append(Result(self.goal, self._values(state, False, False), GOAL_CANCELED))
        self.goal = goal
        self.target = position
        self._last_movement = state.sim_time_ns
        out.commands.append(Command(self.joint, position=position, velocity=0.0))
        return out

    def on_cancel(self, action: str, goal: int, state: JointReadings) -> ControllerOutput:
        """Cancel: hold the current position."""
        out = ControllerOutput()
        if goal == self.goal:
            self.target = state.position[self.joint]
            out.commands.append(Command(self.joint, position=self.target, velocity=0.0))
            out.results.append(Result(goal, self._values(state, False, False), GOAL_CANCELED))
            self.goal = None
        return out

    def update(self, state: JointReadings, period_ns: int) -> ControllerOutput:
        """Check the active goal for success or a stall."""
        goal = self.goal
        if not self.active or goal is None:
            return NOTHING
        out = ControllerOutput()
        now = state.sim_time_ns
        position = state.position[self.joint]
        if abs(self.target - position) < self.goal_tolerance:
            out.results.append(Result(goal, self._values(state, False, True), GOAL_SUCCEEDED))
            self.goal = None
        elif abs(state.velocity[self.joint]) > self.stall_velocity:
            self._last_movement = now
        elif now - self._last_movement > self.stall_timeout_ns:
            status = GOAL_SUCCEEDED if self.allow_stalling else GOAL_ABORTED
            out.results.append(Result(goal, self._values(state, True, False), status))
            self.goal = None
        return out


@controller_type(*GRIPPER_TYPES)
def _gripper(spec: ControllerSpec, robot: RobotInterfaces) -> Controller:
    return GripperActionController(spec, robot.source, robot.controllable)
