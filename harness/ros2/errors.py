"""Errors of the native ROS 2 side."""

from __future__ import annotations

from harness.errors import HarnessError

__all__ = ["Ros2Error", "Ros2Unavailable"]


class Ros2Error(HarnessError):
    """The ROS 2 gateway failed (did not start, refused part of the graph, died)."""


class Ros2Unavailable(Ros2Error):
    """No ROS 2 to use here (no rclpy venv, no sourced install, unsupported platform)."""
