"""Drive plugins a robot file declares, as controllers: Gazebo Classic's
``libgazebo_ros_diff_drive.so`` and gz-sim's ``DiffDrive`` system (in a URDF ``<gazebo>``
block or an SDF ``<model>``) become a ``diff_drive_controller/DiffDriveController`` named
after the plugin, with the plugin's joints and geometry, on its command and odometry topics
(``cmd_vel``/``odom`` by default, under the robot's namespace). Like the plugins, it keeps
the last command (no ``cmd_vel_timeout``) and publishes no odometry transform (the session
publishes the floating base's true pose on ``/tf``).

Gazebo Classic's ``libgazebo_ros_planar_move.so`` (in a URDF ``<gazebo>`` block) becomes a
``planar_controller/PlanarController`` on ``cmd_vel`` (``<ros><remapping>cmd_vel:=...``, or
ROS 1's ``<commandTopic>``) publishing ``odom``, driving the robot's floating base (the free
joint of the URDF's root link); like the plugin, it holds the last command."""

from __future__ import annotations

import math
from typing import Any

from lxml import etree

from harness.controllers.config import ControllerSpec
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE
from harness.controllers.errors import ControllersConfigError
from harness.controllers.planar import TYPE_PLANAR
from harness.models.build.drive_plugins import drive_plugin_elements

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
    return (*specs, *_planar_plugins(root, source))


_PLANAR = "libgazebo_ros_planar_move.so"


def _remapped(plugin: etree._Element, name: str) -> str | None:
    for e in plugin.findall("ros/remapping"):
        text = (e.text or "").strip()
        if text.startswith(f"{name}:=") or text.startswith(f"~/{name}:="):
            return text.split(":=", 1)[1].strip()
    return None


def _urdf_root(root: etree._Element) -> str | None:
    if root.tag != "robot":
        return None
    links = [link.get("name", "") for link in root.findall("link")]
    children = {c.get("link", "") for c in root.findall("joint/child")}
    roots = [link for link in links if link and link not in children]
    return roots[0] if len(roots) == 1 else None


def _planar_plugins(root: etree._Element, source: str) -> list[ControllerSpec]:
    specs: list[ControllerSpec] = []
    base = _urdf_root(root)
    for plugin in root.iter("plugin"):
        if plugin.get("filename", "") != _PLANAR:
            continue
        where = f"{source}: line {plugin.sourceline}: <plugin filename={_PLANAR!r}>"
        cmd = _remapped(plugin, "cmd_vel") or (_texts(plugin, "commandTopic") or ["cmd_vel"])[0]
        odom = _remapped(plugin, "odom") or (_texts(plugin, "odometryTopic") or ["odom"])[0]
        frame = (_texts(plugin, "robot_base_frame") or _texts(plugin, "robotBaseFrame")
                 or ["base_footprint"])[0]  # fmt: skip
        params: dict[str, Any] = {
            "cmd_vel_timeout": _NO_TIMEOUT,
            "use_stamped_vel": False,
            "enable_odom_tf": False,
            "cmd_vel_topic": "/" + cmd.lstrip("/"),
            "odom_topic": "/" + odom.lstrip("/"),
            "odom_frame_id": (_texts(plugin, "odometry_frame") or _texts(plugin, "odometryFrame")
                              or ["odom"])[0],
            "base_frame_id": frame,
            "base_joint": f"{base or frame}::__free__",
        }  # fmt: skip
        rate = _number(plugin, "publish_rate", where) or _number(plugin, "odometryRate", where)
        if rate is not None:
            params["publish_rate"] = rate
        name = plugin.get("name") or "planar_move"
        specs.append(ControllerSpec(name.replace("::", "_").replace(".", "_"), TYPE_PLANAR, params))
    return specs
