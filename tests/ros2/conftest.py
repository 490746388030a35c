"""ROS 2 tests: real rclpy nodes in their own processes (the ROS 2 venv `make ros2` builds, or
a sourced ROS 2). They skip, saying why, where ROS 2 is not available (the PyPI wheels are
x86_64 Linux only)."""

from __future__ import annotations

import pytest

from harness.ros2 import Ros2Install, Ros2Unavailable, find_ros2


@pytest.fixture(scope="session")
def ros2() -> Ros2Install:
    try:
        return find_ros2()
    except Ros2Unavailable as exc:
        pytest.skip(str(exc))
