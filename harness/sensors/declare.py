"""Sensor declarations read from the raw robot and world files.

- URDF: ``<gazebo reference="link"><sensor type=... name=...>`` blocks (Gazebo Classic and
  gz-sim spellings); a sensor in a ``<gazebo>`` block without ``reference`` is refused.
- SDF (1.4-1.11): ``<sensor>`` elements of a ``<link>`` (pose in the link frame) and of a
  ``<joint>`` (force-torque: mounted on the joint's child link).
- Ground truth plugins: Gazebo Classic's ``libgazebo_ros_p3d.so`` and gz-sim's
  ``OdometryPublisher`` system are ``ground_truth`` sensors.
- MJCF has no rate or topic: its ``<camera>`` and ``<site>`` elements are used by name from a
  ``sensors:`` list (``camera: wrist``, ``site: imu``); nothing is published unasked.

Sensor types: each sensor module registers the Gazebo spellings of its kind
(:mod:`harness.sensors.registry`): ``camera``; ``depth`` (Gazebo Classic: image and depth, as
``rgbd``), ``depth_camera``; ``rgbd_camera``; ``ray``, ``gpu_ray``, ``lidar``, ``gpu_lidar``;
``imu``; ``force_torque``; ``contact``. Other types (``gps``, ``altimeter``...) are skipped.

Topic names (overridable per output with ``topics``): a Gazebo ROS plugin's (``<remapping>``
of ``~/out``, ROS 1's ``<topicName>``, under its ``<ros><namespace>``/``<robotNamespace>``);
else with a ``<topic>`` (gz-sim) the main output is on it (a camera's ``camera_info`` beside
it); without one, Gazebo Classic's plugin names under ``<camera_name>`` or the sensor name
(``image_raw``, ``camera_info``, ``depth/image_raw``, ``points``; ``scan``; ``imu``;
``wrench``; ``contacts``). The frame id is the plugin's ``<frame_name>`` (``<frameName>``),
else ``<gz_frame_id>``, else the sensor name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models import ModelError, parse_xml_kept
from harness.sensors.errors import SensorConfigError
from harness.sensors.registry import gazebo_kind
from harness.sensors.sdf_values import element_number, element_text
from harness.sensors.spec import SensorSpec, sensor_token

__all__ = ["declared_in_sources", "sensors_from_sdf", "sensors_from_urdf"]


_URDF_SUFFIXES = (".urdf", ".xacro")
_SDF_SUFFIXES = (".sdf", ".world")


def _pose(el: etree._Element, where: str) -> tuple[float, ...] | None:
    text = element_text(el, "pose")
    if not text:
        return None
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise SensorConfigError(f"{where}: <pose> {text!r} is not 6 numbers") from None
    if len(values) != 6:
        raise SensorConfigError(f"{where}: <pose> {text!r} is not 6 numbers (x y z r p y)")
    return values


def _plugin(sensor: etree._Element) -> tuple[str, str, str]:
    """(camera name, frame name, topic) from a Gazebo ROS plugin: the topic remapped from
    ``~/out`` (ROS 2) or named by ``<topicName>`` (ROS 1), under the plugin's ``<ros><namespace>``
    (ROS 1: ``<robotNamespace>``) when relative; a camera's name under it too."""
    camera = frame = topic = ""
    for plugin in sensor.findall("plugin"):
        camera = camera or (
            element_text(plugin, "camera_name") or element_text(plugin, "cameraName") or ""
        )
        frame = frame or (
            element_text(plugin, "frame_name") or element_text(plugin, "frameName") or ""
        )
        namespace = (
            element_text(plugin, "ros/namespace") or element_text(plugin, "robotNamespace") or ""
        ).rstrip("/")
        own = ""
        for remap in plugin.findall("ros/remapping") + plugin.findall("ros/argument"):
            text = (remap.text or "").strip()
            if ":=" in text:
                left, right = (s.strip() for s in text.split(":=", 1))
                if left in ("~/out", "out", "/out") and right:
                    own = own or right
        own = own or element_text(plugin, "topicName") or ""
        if own and not topic:
            topic = own if own.startswith("/") or not namespace else f"{namespace}/{own}"
        if namespace and camera and not camera.startswith("/"):
            camera = f"{namespace}/{camera}"
    return camera, frame, topic


def _remapped_outputs(sensor: etree._Element, topics: Mapping[str, str]) -> dict[str, str]:
    """``topics`` (output -> name) with a plugin's remappings of its other outputs applied
    (``~/image_raw:=image``, ``front_camera/camera_info:=info``: matched by their last names),
    relative ones under the plugin's namespace."""
    out = dict(topics)
    for plugin in sensor.findall("plugin"):
        namespace = (
            element_text(plugin, "ros/namespace") or element_text(plugin, "robotNamespace") or ""
        ).rstrip("/")
        for remap in plugin.findall("ros/remapping") + plugin.findall("ros/argument"):
            left, _, right = ((remap.text or "").strip()).partition(":=")
            name, right = left.strip().removeprefix("~").strip("/"), right.strip()
            if not right or not name or name == "out":
                continue
            target = right if right.startswith("/") or not namespace else f"{namespace}/{right}"
            for key, topic in topics.items():
                own = topic.strip("/")
                if own == name or own.endswith("/" + name):
                    out[key] = target
    return out


_PLUGIN_RATES = ("updateRateHZ", "updateRate", "update_rate")
"""A Gazebo ROS plugin's own publishing rate (ROS 1 plugins; 0 or absent: the sensor's)."""


def _plugin_rate(sensor: etree._Element, where: str) -> float | None:
    for plugin in sensor.findall("plugin"):
        for tag in _PLUGIN_RATES:
            value = element_number(plugin, tag, where)
            if value is not None and value > 0:
                return value
    return None


def _rate(sensor: float | None, plugin: float | None) -> float | None:
    """The rate messages come at: the sensor's, throttled by its plugin's."""
    if plugin is None or (sensor is not None and 0 < sensor <= plugin):
        return sensor
    return plugin


def _sensor(sensor: etree._Element, parent: str, source: str, joint: str = "") -> SensorSpec | None:
    raw_type = sensor.get("type", "")
    name = sensor.get("name", "")
    where = f"{source}: <sensor name={name!r} type={raw_type!r}> on {parent!r}"
    kind = gazebo_kind(raw_type)
    if kind is None:
        return None
    if not name:
        raise SensorConfigError(f"{where}: a sensor needs a name")
    camera_name, frame_name, plugin_topic = _plugin(sensor)
    # a ROS plugin's topic is the one ROS sees; <topic> is Gazebo's own (bridged by gz-sim)
    topic = plugin_topic or element_text(sensor, "topic")
    params: dict[str, Any] = {}
    rate = _rate(element_number(sensor, "update_rate", where), _plugin_rate(sensor, where))
    if rate is not None:
        params["update_rate"] = rate
    pose = _pose(sensor, where)
    if pose is not None:
        params["pose"] = pose
    params.update(kind.params(sensor, where))
    frame_id = frame_name or element_text(sensor, "gz_frame_id") or ""
    try:
        return SensorSpec.make(
            name=name,
            type=kind.type,
            parent=parent,
            joint=joint,
            topic=topic or "",
            topics=_remapped_outputs(
                sensor, kind.default_topics(topic or "", camera_name or sensor_token(name))
            ),
            frame_id=frame_id,
            source=source,
            **params,
        )
    except SensorConfigError as exc:
        raise SensorConfigError(f"{where}: {exc}") from None


_P3D = ("libgazebo_ros_p3d.so",)
_ODOMETRY_PUBLISHER = (
    "gz-sim-odometry-publisher-system",
    "libgz-sim-odometry-publisher-system.so",
    "ignition-gazebo-odometry-publisher-system",
    "libignition-gazebo-odometry-publisher-system.so",
)


def _ground_truth_plugins(root: etree._Element, source: str, base: str) -> list[SensorSpec]:
    """Gazebo Classic's ``libgazebo_ros_p3d.so`` (``<body_name>``/``<bodyName>``, its
    ``odom`` topic remapped or ROS 1's ``<topicName>``, ``<frame_name>``, ``<update_rate>``)
    and gz-sim's ``OdometryPublisher`` (``<robot_base_frame>``, ``<odom_topic>``,
    ``<odom_frame>``, ``<odom_publish_frequency>``) as ``ground_truth`` sensors; ``base``: the
    link a gz-sim plugin without ``<robot_base_frame>`` follows."""
    out: list[SensorSpec] = []
    for plugin in root.iter("plugin"):
        filename = plugin.get("filename", "")
        if filename not in _P3D + _ODOMETRY_PUBLISHER:
            continue
        name = plugin.get("name") or "ground_truth"
        where = f"{source}: line {plugin.sourceline}: <plugin filename={filename!r}>"
        namespace = (
            element_text(plugin, "ros/namespace") or element_text(plugin, "robotNamespace") or ""
        ).rstrip("/")
        if filename in _P3D:
            body = element_text(plugin, "body_name") or element_text(plugin, "bodyName") or ""
            topic = element_text(plugin, "topicName") or "odom"
            for remap in plugin.findall("ros/remapping"):
                left, _, right = (remap.text or "").partition(":=")
                if left.strip().removeprefix("~").lstrip("/") == "odom" and right.strip():
                    topic = right.strip()
            frame = element_text(plugin, "frame_name") or element_text(plugin, "frameName")
            rate = element_number(plugin, "update_rate", where) or element_number(
                plugin, "updateRate", where
            )
        else:
            body = element_text(plugin, "robot_base_frame") or base
            topic = element_text(plugin, "odom_topic") or "odom"
            frame = element_text(plugin, "odom_frame") or "odom"
            rate = element_number(plugin, "odom_publish_frequency", where)
        if not body:
            raise SensorConfigError(f"{where}: needs <body_name>")
        if namespace and not topic.startswith("/"):
            topic = f"{namespace}/{topic}"
        try:
            out.append(
                SensorSpec(
                    name=name, type="ground_truth", parent=body, topic=topic,
                    topics={"odom": topic}, frame_id=frame or "world", source=source,
                    update_rate=rate or None,
                )
            )  # fmt: skip
        except SensorConfigError as exc:
            raise SensorConfigError(f"{where}: {exc}") from None
    return out


def sensors_from_urdf(
    data: bytes, source: str = "robot.urdf", *, plugins: bool = True
) -> list[SensorSpec]:
    """The sensors of the URDF ``<gazebo reference>`` blocks in ``data`` (``plugins``: and its
    ground truth plugins)."""
    root = parse_xml_kept(bytes(data), source)
    out: list[SensorSpec] = []
    # Gazebo force-torque sensors reference a joint: they sit on its child link.
    children = {j.get("name", ""): element_text(j, "child") or "" for j in root.iter("joint")}
    for j in root.iter("joint"):
        child = j.find("child")
        if child is not None and child.get("link"):
            children[j.get("name", "")] = child.get("link", "")
    for gazebo in root.iter("gazebo"):
        sensors = gazebo.findall("sensor")
        if not sensors:
            continue
        reference = gazebo.get("reference", "")
        if not reference:
            raise SensorConfigError(
                f"{source}: line {gazebo.sourceline}: a <gazebo> block with a <sensor> needs "
                'reference="link"'
            )
        for sensor in sensors:
            if reference in children:
                spec = _sensor(sensor, children[reference], source, joint=reference)
            else:
                spec = _sensor(sensor, reference, source)
            if spec is not None:
                out.append(spec)
    return out + (_ground_truth_plugins(root, source, "") if plugins else [])


def sensors_from_sdf(
    data: bytes, source: str = "model.sdf", *, plugins: bool = True
) -> list[SensorSpec]:
    """The sensors of the SDF ``<link>`` and ``<joint>`` elements in ``data`` (``plugins``: and
    its ground truth plugins)."""
    root = parse_xml_kept(bytes(data), source)
    out: list[SensorSpec] = []
    for link in root.iter("link"):
        for sensor in link.findall("sensor"):
            spec = _sensor(sensor, link.get("name", ""), source)
            if spec is not None:
                out.append(spec)
    for joint in root.iter("joint"):
        child = element_text(joint, "child") or ""
        for sensor in joint.findall("sensor"):
            spec = _sensor(sensor, child, source, joint=joint.get("name", ""))
            if spec is not None:
                out.append(spec)
    if not plugins:
        return out
    first = next(iter(root.iter("link")), None)
    return out + _ground_truth_plugins(root, source, "" if first is None else first.get("name", ""))


def declared_in_sources(sources: Mapping[str, bytes]) -> list[SensorSpec]:
    """The sensors declared in a loaded robot's source files (``"<role>/<file name>"`` ->
    bytes: URDF/xacro and SDF model and scene files; MJCF declares none by itself)."""
    out: list[SensorSpec] = []
    for key, blob in sources.items():
        role, _, name = key.partition("/")
        if role not in ("model", "scene"):
            continue
        lower = name.lower()
        try:
            # a ground truth plugin follows a robot's link: the robot's own files only
            if lower.endswith(_URDF_SUFFIXES):
                out.extend(sensors_from_urdf(blob, name, plugins=role == "model"))
            elif lower.endswith(_SDF_SUFFIXES):
                out.extend(sensors_from_sdf(blob, name, plugins=role == "model"))
        except ModelError as exc:
            raise SensorConfigError(f"{name}: cannot read sensors: {exc}") from None
    return out
