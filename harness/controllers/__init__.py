"""ros2_control's controllers, simulated: what sits between a ROS interface and the simulation's
inputs.

One module per controller kind, each sans-I/O (messages, goals and cancels in at a step
boundary, joint commands and messages out: :mod:`harness.controllers.base`):
:mod:`~harness.controllers.joint_trajectory` (``~/joint_trajectory`` and the
FollowJointTrajectory action, interpolation and tolerances in :mod:`~harness.controllers.spline`),
:mod:`~harness.controllers.forward_command`, :mod:`~harness.controllers.gripper_action`,
:mod:`~harness.controllers.broadcaster`; the controllers YAML (:mod:`~harness.controllers.config`)
and the controller manager with its services (:mod:`~harness.controllers.manager`). The session
binds them to the bridge (:mod:`harness.session.core.control`).

The room's rule: **a new controller is one module in this room and touches no core file.** The
module subclasses :class:`ControllerBase` (the no-op defaults) and registers a factory for its
ros2_controllers type string with :func:`~harness.controllers.registry.controller_type`; the
manager finds it by walking this package (:mod:`~harness.controllers.registry`), lists it in
``list_controller_types`` and builds it from a controllers YAML. A type no module registers
is one line naming it and the known types. A controller that reads a sensor is built with the
robot's sensors as state interfaces (:class:`SensorInterfaces`, ``<sensor>/<interface>``), so
a broadcaster of a sensor is one more such module.
"""

from harness.controllers.base import (
    GOAL_ABORTED,
    GOAL_CANCELED,
    GOAL_SUCCEEDED,
    NOTHING,
    ActionEndpoint,
    BaseVelocity,
    Command,
    Controller,
    ControllerBase,
    ControllerOutput,
    Feedback,
    JointReadings,
    LogLine,
    Publication,
    Result,
    SensorInterfaces,
    TopicEndpoint,
)
from harness.controllers.command_topics import FORWARD_TOPICS, Reporter, RobotCommands, Trajectory
from harness.controllers.config import (
    ControllersConfig,
    ControllerSpec,
    builtin_controllers,
    default_controllers,
    load_controllers,
)
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE
from harness.controllers.errors import (
    CommandRefused,
    ControllerError,
    ControllersConfigError,
    ControllersWarning,
    UnknownControllerType,
)
from harness.controllers.gazebo_plugins import BASE_CONTROLLER_TYPES, robot_controllers
from harness.controllers.listed import ListedJoints
from harness.controllers.manager import SERVICES, ControllerManager, make_controller
from harness.controllers.planar import TYPE_PLANAR
from harness.controllers.registry import RobotInterfaces, controller_type, known_types
from harness.controllers.substitutions import ARG_NAME
from harness.controllers.values import JointArray, JointIndex

__all__ = [
    "ARG_NAME",
    "BASE_CONTROLLER_TYPES",
    "FORWARD_TOPICS",
    "GOAL_ABORTED",
    "GOAL_CANCELED",
    "GOAL_SUCCEEDED",
    "NOTHING",
    "SERVICES",
    "TYPE_DIFF_DRIVE",
    "TYPE_PLANAR",
    "ActionEndpoint",
    "BaseVelocity",
    "Command",
    "CommandRefused",
    "Controller",
    "ControllerBase",
    "ControllerError",
    "ControllerManager",
    "ControllerOutput",
    "ControllerSpec",
    "ControllersConfig",
    "ControllersConfigError",
    "ControllersWarning",
    "Feedback",
    "JointArray",
    "JointIndex",
    "JointReadings",
    "ListedJoints",
    "LogLine",
    "Publication",
    "Reporter",
    "Result",
    "RobotCommands",
    "RobotInterfaces",
    "SensorInterfaces",
    "TopicEndpoint",
    "Trajectory",
    "UnknownControllerType",
    "builtin_controllers",
    "controller_type",
    "default_controllers",
    "known_types",
    "load_controllers",
    "make_controller",
    "robot_controllers",
]
