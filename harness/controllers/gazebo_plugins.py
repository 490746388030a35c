"""Drive plugins a robot file declares, as controllers: Gazebo Classic's
``libgazebo_ros_diff_drive.so`` and gz-sim's ``DiffDrive`` system (in a URDF ``<gazebo>``
block or an SDF ``<model>``) become a ``diff_drive_controller/DiffDriveController`` named
after the plugin, with the plugin's joints and geometry, on its command and odometry topics
(``cmd_vel``/``odom`` by default, under the robot's namespace). Like the plugins, it keeps
the last command (no ``cmd_vel_timeout``) and publishes no odometry transform (the session
publishes the floating base's true pose on ``/tf``)."""

from __future__ import annotations

import math
from typing import Any

from lxml import etree

from harness.controllers.config import ControllerSpec
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE
from harness.controllers.errors import ControllersConfigError
from harness.models.drive_plugins import drive_plugin_elements

__all__ = ["drive_plugins"]

_CLASSIC = "libgazebo_ros_diff_drive.so"
_NO_TIMEOUT = 1e9  # seconds: the plugins hold the last command


def _texts(plugin: etree._Element, tag: str) -> list[str]:
    return [(e.text or "").strip() for e in plugin.findall(tag) if (e.text or "").strip()]


def _number(plugin: etree._Element, tag: str, where: str) -> float | None:
    found = _texts(plugin, tag)
    if not found:
        return None
    try:
        value = float(found[0])
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ControllersConfigError(f"{where}: <{tag}> {found[0]!r} is not a positive number")
    return value


def drive_plugins(root: etree._Element, source: str) -> tuple[ControllerSpec, ...]:
    """The diff drive controllers of the file's drive plugins (see the module docstring)."""
    specs: list[ControllerSpec] = []
    for plugin in drive_plugin_elements(root):
        where = f"{source}: line {plugin.sourceline}: <plugin filename={plugin.get('filename')!r}>"
        classic = plugin.get("filename", "") == _CLASSIC
        left, right = _texts(plugin, "left_joint"), _texts(plugin, "right_joint")
        if not left or not right:
            raise ControllersConfigError(f"{where}: needs <left_joint> and <right_joint>")
        separation = _number(plugin, "wheel_separation", where)
        if classic:
            diameter = _number(plugin, "wheel_diameter", where)
            radius = None if diameter is None else diameter / 2
        else:
            radius = _number(plugin, "wheel_radius", where)
        if separation is None or radius is None:
            size = "wheel_diameter" if classic else "wheel_radius"
            raise ControllersConfigError(f"{where}: needs <wheel_separation> and <{size}>")
        cmd = (_texts(plugin, "command_topic" if classic else "topic") or ["cmd_vel"])[0]
        odom = (_texts(plugin, "odometry_topic" if classic else "odom_topic") or ["odom"])[0]
        params: dict[str, Any] = {
            "left_wheel_names": left,
            "right_wheel_names": right,
            "wheel_separation": separation,
            "wheel_radius": radius,
            "cmd_vel_timeout": _NO_TIMEOUT,
            "use_stamped_vel": False,
            "enable_odom_tf": False,
            "cmd_vel_topic": "/" + cmd.lstrip("/"),  # the robot's namespace: see the README
            "odom_topic": "/" + odom.lstrip("/"),
            "odom_frame_id": (_texts(plugin, "odometry_frame" if classic else "frame_id")
                              or ["odom"])[0],
            "base_frame_id": (_texts(plugin, "robot_base_frame" if classic else "child_frame_id")
                              or ["base_footprint" if classic else "base_link"])[0],
        }  # fmt: skip
        rate = _number(plugin, "update_rate" if classic else "odom_publish_frequency", where)
        if rate is not None:
            params["publish_rate"] = rate
        name = plugin.get("name") or "diff_drive"
        specs.append(
            ControllerSpec(name.replace("::", "_").replace(".", "_"), TYPE_DIFF_DRIVE, params)
        )
    return tuple(specs)
