"""Drive plugins a robot file declares, as controllers: Gazebo Classic's
``libgazebo_ros_diff_drive.so`` and gz-sim's ``DiffDrive`` system (in a URDF ``<gazebo>``
block or an SDF ``<model>``) become a ``diff_drive_controller/DiffDriveController`` named
after the plugin, with the plugin's joints and geometry, on its command and odometry topics
(``cmd_vel``/``odom`` by default). Like the plugins, it keeps the last command (no
``cmd_vel_timeout``) and publishes no odometry transform (the session publishes the floating
base's true pose on ``/tf``).

Gazebo Classic's ``libgazebo_ros_planar_move.so`` (in a URDF ``<gazebo>`` block) becomes a
``planar_controller/PlanarController`` on ``cmd_vel`` publishing ``odom``, driving the robot's
floating base (the free joint of the URDF's root link); like the plugin, it holds the last
command.

Topics as the plugins name them: a Classic plugin's ``<ros><namespace>`` and
``<ros><remapping>`` (``cmd_vel:=cmd_demo``, ``odom:=odom/unfiltered``, also with ``~/``) or
ROS 1's ``<robotNamespace>``, ``<commandTopic>``, ``<odometryTopic>``; gz-sim's ``<topic>`` and
``<odom_topic>``. A relative name lives under the plugin's namespace, else at the root. Rates:
Classic's ``<update_rate>`` (``<updateRate>``, ``<publish_rate>``, ``<odometryRate>``), gz-sim's
``<odom_publish_frequency>`` (also as ``<odom_publisher_frequency>``, the spelling of
TurtleBot3's and many other robot files, which gz-sim itself ignores).

:func:`robot_controllers` is the one translation every entry point uses (``Session``,
``harness serve``, ``harness run`` and the pytest marker): a robot's default controllers plus
its files' drive plugins.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from lxml import etree

from harness.controllers.config import (
    TYPE_JOINT_STATE_BROADCASTER,
    ControllersConfig,
    ControllerSpec,
    load_controllers,
)
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE
from harness.controllers.errors import ControllersConfigError, ControllersWarning
from harness.controllers.planar import TYPE_PLANAR
from harness.models import drive_plugin_elements, parse_xml_kept

__all__ = ["BASE_CONTROLLER_TYPES", "ROS2_CONTROL_PLUGINS", "drive_plugins", "robot_controllers"]

BASE_CONTROLLER_TYPES = frozenset({TYPE_DIFF_DRIVE, TYPE_PLANAR})
"""Controller types that move a mobile base."""

_CLASSIC = "libgazebo_ros_diff_drive.so"  # ROS 2 and ROS 1 alike
_PLANAR = "libgazebo_ros_planar_move.so"
_NO_TIMEOUT = 1e9  # seconds: the plugins hold the last command
_MODEL_SUFFIXES = (".urdf", ".sdf", ".xacro", ".world")


def _texts(plugin: etree._Element, *tags: str) -> list[str]:
    """The texts of the first of ``tags`` the plugin has (its spellings, newest first)."""
    for tag in tags:
        found = [(e.text or "").strip() for e in plugin.findall(tag) if (e.text or "").strip()]
        if found:
            return found
    return []


def _number(plugin: etree._Element, where: str, *tags: str) -> float | None:
    for tag in tags:
        found = _texts(plugin, tag)
        if not found:
            continue
        try:
            value = float(found[0])
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise ControllersConfigError(f"{where}: <{tag}> {found[0]!r} is not a positive number")
        return value
    return None


def _namespace(plugin: etree._Element) -> str:
    """The plugin's ROS namespace (``<ros><namespace>``, ROS 1's ``<robotNamespace>``)."""
    found = _texts(plugin, "ros/namespace", "robotNamespace")
    return found[0].strip("/") if found else ""


def _remapped(plugin: etree._Element, name: str) -> str | None:
    """What ``<ros><remapping>`` (or ``<argument>``) maps ``name`` to (also ``~/name``)."""
    for e in [*plugin.findall("ros/remapping"), *plugin.findall("ros/argument")]:
        text = (e.text or "").strip()
        if ":=" not in text:
            continue
        left, right = (part.strip() for part in text.split(":=", 1))
        if left.removeprefix("~").lstrip("/") == name and right:
            return right
    return None


def _topic(plugin: etree._Element, default: str, *tags: str) -> str:
    """The absolute topic of the plugin's ``default`` name: remapped, or named by ``tags``,
    under the plugin's namespace when relative."""
    name = _remapped(plugin, default) or (_texts(plugin, *tags) or [default])[0]
    if name.startswith("/"):
        return name
    namespace = _namespace(plugin)
    return f"/{namespace}/{name}" if namespace else f"/{name}"


def _controller_name(plugin: etree._Element, default: str) -> str:
    name = plugin.get("name") or default
    return name.replace("::", "_").replace(".", "_")


def drive_plugins(root: etree._Element, source: str) -> tuple[ControllerSpec, ...]:
    """The diff drive controllers of the file's drive plugins (see the module docstring)."""
    specs: list[ControllerSpec] = []
    for plugin in drive_plugin_elements(root):
        where = f"{source}: line {plugin.sourceline}: <plugin filename={plugin.get('filename')!r}>"
        classic = plugin.get("filename", "") == _CLASSIC
        left = _texts(plugin, "left_joint", "leftJoint")
        right = _texts(plugin, "right_joint", "rightJoint")
        if not left or not right:
            raise ControllersConfigError(f"{where}: needs <left_joint> and <right_joint>")
        separation = _number(plugin, where, "wheel_separation", "wheelSeparation")
        if classic:
            diameter = _number(plugin, where, "wheel_diameter", "wheelDiameter")
            radius = None if diameter is None else diameter / 2
        else:
            radius = _number(plugin, where, "wheel_radius")
        if separation is None or radius is None:
            size = "wheel_diameter" if classic else "wheel_radius"
            raise ControllersConfigError(f"{where}: needs <wheel_separation> and <{size}>")
        if classic:
            cmd = _topic(plugin, "cmd_vel", "command_topic", "commandTopic")
            odom = _topic(plugin, "odom", "odometry_topic", "odometryTopic")
            odom_frame = _texts(plugin, "odometry_frame", "odometryFrame") or ["odom"]
            base_frame = _texts(plugin, "robot_base_frame", "robotBaseFrame") or ["base_footprint"]
            rate = _number(plugin, where, "update_rate", "updateRate")
        else:
            cmd = _topic(plugin, "cmd_vel", "topic")
            odom = _topic(plugin, "odom", "odom_topic")
            odom_frame = _texts(plugin, "frame_id") or ["odom"]
            base_frame = _texts(plugin, "child_frame_id") or ["base_link"]
            rate = _number(plugin, where, "odom_publish_frequency", "odom_publisher_frequency")
        params: dict[str, Any] = {
            "left_wheel_names": left,
            "right_wheel_names": right,
            "wheel_separation": separation,
            "wheel_radius": radius,
            "cmd_vel_timeout": _NO_TIMEOUT,
            "use_stamped_vel": False,
            "enable_odom_tf": False,
            "cmd_vel_topic": cmd,
            "odom_topic": odom,
            "odom_frame_id": odom_frame[0],
            "base_frame_id": base_frame[0],
        }
        if rate is not None:
            params["publish_rate"] = rate
        specs.append(
            ControllerSpec(_controller_name(plugin, "diff_drive"), TYPE_DIFF_DRIVE, params)
        )
    return (*specs, *_planar_plugins(root, source))


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
        frame = _texts(plugin, "robot_base_frame", "robotBaseFrame") or ["base_footprint"]
        params: dict[str, Any] = {
            "cmd_vel_timeout": _NO_TIMEOUT,
            "use_stamped_vel": False,
            "enable_odom_tf": False,
            "cmd_vel_topic": _topic(plugin, "cmd_vel", "commandTopic"),
            "odom_topic": _topic(plugin, "odom", "odometryTopic"),
            "odom_frame_id": (_texts(plugin, "odometry_frame", "odometryFrame") or ["odom"])[0],
            "base_frame_id": frame[0],
            "base_joint": f"{base or frame[0]}::__free__",
        }
        rate = _number(plugin, where, "publish_rate", "update_rate", "odometryRate")
        if rate is not None:
            params["publish_rate"] = rate
        specs.append(ControllerSpec(_controller_name(plugin, "planar_move"), TYPE_PLANAR, params))
    return specs


ROS2_CONTROL_PLUGINS = (
    "gz_ros2_control-system",
    "libgz_ros2_control-system.so",
    "ign_ros2_control-system",
    "libign_ros2_control-system.so",
    "libgazebo_ros2_control.so",
)
"""Plugin file names of the simulators' ros2_control (gz-sim, its former Ignition name, Classic)."""
_TOPIC_PARAMS = {
    "cmd_vel": "cmd_vel_topic",
    "cmd_vel_unstamped": "cmd_vel_topic",
    "odom": "odom_topic",
}


def _parameter_files(root: etree._Element, source: str) -> list[tuple[Path, etree._Element]]:
    """The ``<parameters>`` files of the file's ros2_control plugin tags, with their plugin."""
    out: list[tuple[Path, etree._Element]] = []
    for plugin in root.iter("plugin"):
        if plugin.get("filename", "") not in ROS2_CONTROL_PLUGINS:
            continue
        for text in _texts(plugin, "parameters"):
            path = Path(text.removeprefix("file://"))
            if not path.is_file():
                # a description used without its control package (a package:// the loader
                # did not resolve): the robot still loads, with the harness's default set
                warnings.warn(
                    f"{source}: line {plugin.sourceline}: <plugin "
                    f"filename={plugin.get('filename')!r}>: <parameters> {text!r} is no file: "
                    "the harness's default controllers are served instead",
                    ControllersWarning,
                    stacklevel=2,
                )
                continue
            out.append((path, plugin))
    return out


def _plugin_remaps(config: ControllersConfig, plugin: etree._Element) -> ControllersConfig:
    """``config`` with the plugin's namespace and remappings of controller topics
    (``/<controller>/cmd_vel:=/cmd_vel``, ``odom``) applied as the base controllers' topic
    parameters, relative names under the plugin's namespace."""
    namespace = _namespace(plugin)
    specs = []
    for spec in config.controllers:
        params = dict(spec.params)
        if namespace and spec.type in BASE_CONTROLLER_TYPES:  # their ~/ topics in the namespace
            for topic, key in (("cmd_vel", "cmd_vel_topic"), ("odom", "odom_topic")):
                if str(params.get(key, "~/")).startswith("~/"):
                    default = str(params.get(key, f"~/{topic}")).removeprefix("~/")
                    params[key] = f"/{namespace}/{spec.name}/{default}"
        for e in [*plugin.findall("ros/remapping"), *plugin.findall("ros/argument")]:
            text = (e.text or "").strip()
            if ":=" not in text:
                continue
            left, right = (part.strip() for part in text.split(":=", 1))
            node, _, last = left.strip("/").rpartition("/")
            param = _TOPIC_PARAMS.get(last)
            if param is None or node.rpartition("/")[2] != spec.name or not right:
                continue
            params[param] = (
                right if right.startswith("/") else f"/{namespace}/{right}".replace("//", "/")
            )
        specs.append(ControllerSpec(spec.name, spec.type, params))
    return replace(config, controllers=tuple(specs))


def robot_controllers(
    default: ControllersConfig, sources: Mapping[str, bytes]
) -> ControllersConfig:
    """The controllers of a robot given none: the ``<parameters>`` file(s) of its
    ros2_control plugin tag (gz_ros2_control, ign_ros2_control, gazebo_ros2_control; merged in
    order, with the tag's topic remappings), else ``default``; plus the controllers of the
    drive plugins declared in its model files (``sources``: ``"model/<file>"`` -> bytes, as
    :attr:`harness.models.LoadedRobot.sources`)."""
    specs: list[ControllerSpec] = []
    files: list[tuple[Path, etree._Element]] = []
    named: list[str] = []
    for name, data in sources.items():
        if name.startswith("model/") and name.endswith(_MODEL_SUFFIXES):
            root = parse_xml_kept(bytes(data), name)
            files += _parameter_files(root, name)
            found = drive_plugins(root, name)
            if found:
                named.append(name)
            specs += found
    config = default
    if files:
        config = load_controllers([path for path, _ in files])
        for _, plugin in files:
            config = _plugin_remaps(config, plugin)
    if not specs:
        return config
    if not config.exclusive:
        # A robot file that names controllers replaces the harness's default set and its
        # topics, as a YAML does (ros2_control's one-claim rule then holds among them).
        broadcaster = ControllerSpec("joint_state_broadcaster", TYPE_JOINT_STATE_BROADCASTER)
        return ControllersConfig(config.update_rate, (broadcaster, *specs), " + ".join(named))
    return replace(config, controllers=(*config.controllers, *specs))
