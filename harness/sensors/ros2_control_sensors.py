"""The ``<sensor>`` entries of a URDF's ``<ros2_control>`` blocks, simulated as gz_ros2_control
does: as the simulator's sensor of the same name.

gz_ros2_control reads a ``<ros2_control>`` ``<sensor name="X">`` from the simulator's sensor
named ``X`` (an IMU or a force-torque sensor of the model). A robot whose hardware is a vendor's
driver or a mock (ros2_control_demos' examples 4, 5 and 13: ``<sensor name="tcp_fts_sensor">``
with ``force.x`` ... ``torque.z`` state interfaces and ``<param name="frame_id">tool_link``)
has no simulator sensor of that name: the harness adds one, of the kind its state interfaces
name (every interface among a force-torque sensor's: ``force_torque``; among an IMU's:
``imu``), mounted on the link its ``frame_id`` parameter names (the frame its values are in,
as the ros2_control convention has it; a xacro macro that prefixed the sensor's name but
not its ``frame_id`` gets the link with the same prefix) and published in that frame. A
``<sensor>`` whose interfaces fit no kind, or without a ``frame_id`` naming a link, is left
out: a broadcaster that names it is refused with the interfaces the robot has.

Such a sensor is a sensor of the session like a declared one: it also publishes on its default
topic (``/<name>/wrench``, ``/<name>/imu``) and is recorded. A simulated force-torque sensor has
all six interfaces, an IMU all ten, whatever subset the tag
declares: a broadcaster naming ``interface_names`` reads the subset it names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.force_torque import FT_INTERFACES
from harness.sensors.imu import IMU_INTERFACES
from harness.sensors.spec import SensorSpec

__all__ = ["ros2_control_sensors"]

_KINDS: tuple[tuple[str, frozenset[str]], ...] = (
    ("force_torque", frozenset(FT_INTERFACES)),
    ("imu", frozenset(IMU_INTERFACES)),
)


def _kind(interfaces: Sequence[str]) -> str | None:
    for kind, names in _KINDS:
        if interfaces and names.issuperset(interfaces):
            return kind
    return None


def _link(frame: str, sensor: str, links: set[str]) -> str:
    """The link ``frame`` names: itself, else the one a xacro macro prefixed as it prefixed
    the sensor (``frame_id`` ``tool_link`` of the sensor ``rrbot_tcp_fts_sensor`` is
    ``rrbot_tool_link``: ros2_control_demos' example 13 reuses example 5's tag so); "" when
    no link fits."""
    if not frame or frame in links:
        return frame
    fits = [
        link
        for link in links
        if link.endswith(frame) and sensor.startswith(link.removesuffix(frame))
    ]
    return max(fits, key=len) if fits else ""


def ros2_control_sensors(
    sources: Mapping[str, bytes], declared: Sequence[SensorSpec] = ()
) -> list[SensorSpec]:
    """The sensors to add for the ``<ros2_control>`` ``<sensor>`` entries of a robot's URDF
    (``sources``: ``"<role>/<file>"`` -> bytes; the expanded URDF is ``model/*.urdf``) that
    no sensor of ``declared`` (the files' own, by name) stands for."""
    names = {spec.name for spec in declared}
    out: list[SensorSpec] = []
    for key, blob in sources.items():
        role, _, name = key.partition("/")
        if role != "model" or not name.lower().endswith(".urdf"):
            continue
        try:
            root = etree.fromstring(blob, etree.XMLParser(resolve_entities=False, no_network=True))
        except etree.XMLSyntaxError:
            continue  # the model reader has refused it with its own message already
        links = {str(link.get("name")) for link in root.iterfind("link")}
        for sensor in root.iterfind("ros2_control/sensor"):
            sensor_name = sensor.get("name") or ""
            interfaces = [str(i.get("name") or "") for i in sensor.iterfind("state_interface")]
            params = {str(p.get("name")): (p.text or "").strip() for p in sensor.iterfind("param")}
            kind = _kind(interfaces)
            frame = _link(params.get("frame_id", ""), sensor_name, links)
            if not sensor_name or sensor_name in names or kind is None or not frame:
                continue
            names.add(sensor_name)
            out.append(
                SensorSpec(
                    name=sensor_name,
                    type=kind,
                    parent=frame,
                    frame_id=frame,
                    source=f"{name}: <ros2_control> <sensor name={sensor_name!r}>",
                )
            )
    return out
