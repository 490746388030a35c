"""Sensor declarations read from the raw robot and world files.

- URDF: ``<gazebo reference="link"><sensor type=... name=...>`` blocks (Gazebo Classic and
  gz-sim spellings); a sensor in a ``<gazebo>`` block without ``reference`` is refused.
- SDF (1.4-1.11): ``<sensor>`` elements of a ``<link>`` (pose in the link frame) and of a
  ``<joint>`` (force-torque: mounted on the joint's child link).
- MJCF has no rate or topic: its ``<camera>`` and ``<site>`` elements are used by name from a
  ``sensors:`` list (``camera: wrist``, ``site: imu``); nothing is published unasked.

Sensor types: ``camera``; ``depth`` (Gazebo Classic: image and depth, as ``rgbd``),
``depth_camera``; ``rgbd_camera``; ``ray``, ``gpu_ray``, ``lidar``, ``gpu_lidar``; ``imu``;
``force_torque``; ``contact``. Other types (``gps``, ``altimeter``...) are skipped.

Topic names (overridable per output with ``topics``): with a ``<topic>`` (gz-sim) the main
output is on it (a camera's ``camera_info`` beside it); without one, Gazebo Classic's plugin
names under ``<camera_name>`` or the sensor name (``image_raw``, ``camera_info``,
``depth/image_raw``, ``points``; ``scan``; ``imu``; ``wrench``; ``contacts``). The frame id
is the plugin's ``<frame_name>``, else ``<gz_frame_id>``, else the sensor name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.errors import ModelError
from harness.models.xmlsafe import parse_xml
from harness.sensors.errors import SensorConfigError
from harness.sensors.spec import OUTPUTS, SensorSpec, SensorType

__all__ = [
    "GAZEBO_TYPES",
    "declared_in_sources",
    "default_topics",
    "sensors_from_sdf",
    "sensors_from_urdf",
]

GAZEBO_TYPES: Mapping[str, SensorType] = {
    "camera": "camera",
    "depth": "rgbd",
    "depth_camera": "depth",
    "rgbd_camera": "rgbd",
    "rgbd": "rgbd",
    "ray": "lidar",
    "gpu_ray": "lidar",
    "lidar": "lidar",
    "gpu_lidar": "lidar",
    "imu": "imu",
    "force_torque": "force_torque",
    "contact": "contact",
}
"""Gazebo's sensor ``type`` spellings -> the harness's sensor type."""

_URDF_SUFFIXES = (".urdf", ".xacro")
_SDF_SUFFIXES = (".sdf", ".world")


def _text(el: etree._Element | None, path: str) -> str | None:
    if el is None:
        return None
    found = el.find(path)
    if found is None or found.text is None:
        return None
    return str(found.text).strip()


def _number(el: etree._Element | None, path: str, where: str) -> float | None:
    text = _text(el, path)
    if text is None or text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        raise SensorConfigError(f"{where}: <{path}> is {text!r}, not a number") from None
    if not math.isfinite(value):
        raise SensorConfigError(f"{where}: <{path}> is {text!r}, not a finite number")
    return value


def _int(el: etree._Element | None, path: str, where: str) -> int | None:
    value = _number(el, path, where)
    if value is None:
        return None
    if value != int(value):
        raise SensorConfigError(f"{where}: <{path}> is {value}, not an integer")
    return int(value)


def _pose(el: etree._Element, where: str) -> tuple[float, ...] | None:
    text = _text(el, "pose")
    if not text:
        return None
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise SensorConfigError(f"{where}: <pose> {text!r} is not 6 numbers") from None
    if len(values) != 6:
        raise SensorConfigError(f"{where}: <pose> {text!r} is not 6 numbers (x y z r p y)")
    return values


def _noise(el: etree._Element | None, where: str) -> dict[str, float]:
    if el is None:
        return {}
    noise = el.find(".//noise")
    if noise is None:
        return {}
    out: dict[str, float] = {}
    mean = _number(noise, "mean", where)
    stddev = _number(noise, "stddev", where)
    if mean is not None:
        out["noise_mean"] = mean
    if stddev is not None:
        out["noise_stddev"] = stddev
    return out


def _plugin(sensor: etree._Element) -> tuple[str, str, str]:
    """(camera name, frame name, remapped ``~/out``-style topic) from a Gazebo ROS plugin."""
    camera = frame = topic = ""
    for plugin in sensor.findall("plugin"):
        camera = camera or (_text(plugin, "camera_name") or _text(plugin, "cameraName") or "")
        frame = frame or (_text(plugin, "frame_name") or _text(plugin, "frameName") or "")
        topic = topic or (_text(plugin, "topicName") or "")
        namespace = _text(plugin, "ros/namespace") or ""
        for remap in plugin.findall("ros/remapping") + plugin.findall("ros/argument"):
            text = (remap.text or "").strip()
            if ":=" in text:
                left, right = (s.strip() for s in text.split(":=", 1))
                if left in ("~/out", "out") and not topic:
                    topic = f"{namespace.rstrip('/')}/{right}" if namespace else right
        if namespace and camera and not camera.startswith("/"):
            camera = f"{namespace.rstrip('/')}/{camera}"
    return camera, frame, topic


def _camera_params(el: etree._Element | None, where: str) -> dict[str, Any]:
    if el is None:
        return {}
    out: dict[str, Any] = {}
    for key, path in (("hfov", "horizontal_fov"), ("near", "clip/near"), ("far", "clip/far")):
        value = _number(el, path, where)
        if value is not None:
            out[key] = value
    for key, path in (("width", "image/width"), ("height", "image/height")):
        size = _int(el, path, where)
        if size is not None:
            out[key] = size
    out.update(_noise(el, where))
    return out


def _ray_params(el: etree._Element | None, where: str) -> dict[str, Any]:
    if el is None:
        return {}
    out: dict[str, Any] = {}
    for prefix, key in (("scan/horizontal", ""), ("scan/vertical", "vertical_")):
        samples = _int(el, f"{prefix}/samples", where)
        if samples is not None:
            out[f"{key}samples"] = samples
        for name in ("min_angle", "max_angle"):
            value = _number(el, f"{prefix}/{name}", where)
            if value is not None:
                out[f"{key}{name}"] = value
    for name in ("min", "max", "resolution"):
        value = _number(el, f"range/{name}", where)
        if value is not None:
            out[f"range_{name}"] = value
    out.update(_noise(el, where))
    return out


def default_topics(kind: SensorType, topic: str, base: str) -> dict[str, str]:
    """Every output's topic (relative names stay relative: the namespace comes later)."""
    if topic:
        parent = topic.rsplit("/", 1)[0] if "/" in topic.strip("/") else ""
        info = f"{parent}/camera_info" if parent else "camera_info"
        if kind == "camera":
            return {"image": topic, "camera_info": info, "compressed": f"{topic}/compressed"}
        if kind == "depth":
            return {"depth": topic, "camera_info": info, "points": f"{topic}/points"}
        if kind == "rgbd":
            return {
                "image": f"{topic}/image",
                "camera_info": f"{topic}/camera_info",
                "compressed": f"{topic}/image/compressed",
                "depth": f"{topic}/depth_image",
                "points": f"{topic}/points",
            }
        if kind == "lidar":
            return {"scan": topic, "points": f"{topic}/points"}
        output = {"imu": "imu", "force_torque": "wrench", "contact": "contacts"}.get(kind, "odom")
        return {output: topic}
    camera = {
        "image": f"{base}/image_raw",
        "camera_info": f"{base}/camera_info",
        "compressed": f"{base}/image_raw/compressed",
        "depth": f"{base}/depth/image_raw",
        "points": f"{base}/points",
    }
    if kind in ("camera", "depth", "rgbd"):
        return {k: v for k, v in camera.items() if k in OUTPUTS[kind]}
    if kind == "lidar":
        return {"scan": f"{base}/scan", "points": f"{base}/points"}
    if kind == "ground_truth":
        return {"odom": "ground_truth/odom"}
    output = {"imu": "imu", "force_torque": "wrench", "contact": "contacts"}[kind]
    return {output: f"{base}/{output}"}


def _sensor(sensor: etree._Element, parent: str, source: str, joint: str = "") -> SensorSpec | None:
    raw_type = sensor.get("type", "")
    name = sensor.get("name", "")
    where = f"{source}: <sensor name={name!r} type={raw_type!r}> on {parent!r}"
    kind = GAZEBO_TYPES.get(raw_type)
    if kind is None:
        return None
    if not name:
        raise SensorConfigError(f"{where}: a sensor needs a name")
    camera_name, frame_name, plugin_topic = _plugin(sensor)
    topic = _text(sensor, "topic") or plugin_topic
    params: dict[str, Any] = {}
    rate = _number(sensor, "update_rate", where)
    if rate is not None:
        params["update_rate"] = rate
    pose = _pose(sensor, where)
    if pose is not None:
        params["pose"] = pose
    if kind in ("camera", "depth", "rgbd"):
        params.update(_camera_params(sensor.find("camera"), where))
    elif kind == "lidar":
        ray = sensor.find("ray")
        params.update(_ray_params(ray if ray is not None else sensor.find("lidar"), where))
    elif kind == "imu":
        imu = sensor.find("imu")
        gyro = imu.find("angular_velocity") if imu is not None else None
        accel = imu.find("linear_acceleration") if imu is not None else None
        params.update(_noise(gyro if gyro is not None else imu, where))
        if accel is not None:
            params.update({f"accel_{k}": v for k, v in _noise(accel, where).items()})
    elif kind == "force_torque":
        ft = sensor.find("force_torque")
        frame = _text(ft, "frame")
        direction = _text(ft, "measure_direction")
        if frame:
            params["ft_frame"] = frame
        if direction:
            params["ft_direction"] = direction
        params.update(_noise(ft, where))
    elif kind == "contact":
        collision = _text(sensor, "contact/collision")
        if collision:
            params["collision"] = collision
    frame_id = frame_name or _text(sensor, "gz_frame_id") or ""
    try:
        return SensorSpec(
            name=name,
            type=kind,
            parent=parent,
            joint=joint,
            topic=topic or "",
            topics=default_topics(kind, topic or "", camera_name or name),
            frame_id=frame_id,
            source=source,
            **params,
        )
    except SensorConfigError as exc:
        raise SensorConfigError(f"{where}: {exc}") from None


def sensors_from_urdf(data: bytes, source: str = "robot.urdf") -> list[SensorSpec]:
    """The sensors of the URDF ``<gazebo reference>`` blocks in ``data``."""
    root = parse_xml(data, source)
    out: list[SensorSpec] = []
    # Gazebo force-torque sensors reference a joint: they sit on its child link.
    children = {j.get("name", ""): _text(j, "child") or "" for j in root.iter("joint")}
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
    return out


def sensors_from_sdf(data: bytes, source: str = "model.sdf") -> list[SensorSpec]:
    """The sensors of the SDF ``<link>`` and ``<joint>`` elements in ``data``."""
    root = parse_xml(data, source)
    out: list[SensorSpec] = []
    for link in root.iter("link"):
        for sensor in link.findall("sensor"):
            spec = _sensor(sensor, link.get("name", ""), source)
            if spec is not None:
                out.append(spec)
    for joint in root.iter("joint"):
        child = _text(joint, "child") or ""
        for sensor in joint.findall("sensor"):
            spec = _sensor(sensor, child, source, joint=joint.get("name", ""))
            if spec is not None:
                out.append(spec)
    return out


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
            if lower.endswith(_URDF_SUFFIXES):
                out.extend(sensors_from_urdf(blob, name))
            elif lower.endswith(_SDF_SUFFIXES):
                out.extend(sensors_from_sdf(blob, name))
        except ModelError as exc:
            raise SensorConfigError(f"{name}: cannot read sensors: {exc}") from None
    return out
