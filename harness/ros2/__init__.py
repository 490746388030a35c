"""The native ROS 2 side: the session's graph on DDS through an rclpy gateway process (see
:mod:`harness.ros2.node`), with ROS 2 QoS and isolation (loopback discovery, a private domain
id). rclpy runs in an interpreter of its own; this package imports nothing from ROS."""

from harness.ros2.env import (
    DOMAIN_IDS,
    Ros2Install,
    choose_domain_id,
    find_ros2,
    rosbridge_server_rs,
)
from harness.ros2.errors import Ros2Error, Ros2Unavailable
from harness.ros2.gateway import Ros2Gateway

__all__ = [
    "DOMAIN_IDS",
    "Ros2Error",
    "Ros2Gateway",
    "Ros2Install",
    "Ros2Unavailable",
    "choose_domain_id",
    "find_ros2",
    "rosbridge_server_rs",
]
