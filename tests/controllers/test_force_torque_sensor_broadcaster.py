"""``force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster``: a controller fed by a
force-torque sensor's state interfaces, added as one module of the controllers room."""

from __future__ import annotations

import math

import pytest

from harness.controllers import ControllersConfigError, known_types
from harness.session import Session
from harness.testing import connect
from tests.sensors.sensor_helpers import RIG

TYPE = "force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster"
G = 9.81
YAML = f"""
controller_manager:
  ros__parameters:
    update_rate: 100
    ft_broadcaster:
      type: {TYPE}
ft_broadcaster:
  ros__parameters:
    sensor_name: ft
    frame_id: wrist_frame
"""
# a force-torque sensor at the rig's wrist: the hanging 2 kg weight pulls on it
SENSORS = [{"name": "ft", "type": "force_torque", "joint": "wrist", "noise_stddev": 0.05}]


def _ns(msg: dict) -> int:
    return int(msg["header"]["stamp"]["sec"]) * 1_000_000_000 + int(
        msg["header"]["stamp"]["nanosec"]
    )


def test_a_client_receives_what_the_sensor_measures_at_that_step() -> None:
    assert TYPE in known_types()
    with (
        Session(RIG, sensors=SENSORS, controllers=YAML, seed=3) as session,
        connect(session.url) as client,
    ):
        broadcast = client.subscribe("/ft_broadcaster/wrench")
        measured = client.subscribe("/ft/wrench")
        controllers = client.call_service("/controller_manager/list_controllers")
        session.command("swing", position=0.6)
        client.step(60)
        client.sync()
    (entry,) = controllers["controller"]
    assert (entry["name"], entry["state"]) == ("ft_broadcaster", "active")
    assert entry["required_state_interfaces"] == [
        f"ft/{a}" for a in ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")
    ]
    by_stamp = {_ns(m): m for m in measured.messages}
    pairs = [(m, by_stamp[_ns(m)]) for m in broadcast.messages if _ns(m) in by_stamp]
    assert len(pairs) >= 10
    assert len({m["wrench"]["force"]["x"] for m, _ in pairs}) == len(pairs)  # noisy, moving
    for got, sensor in pairs:
        assert got["wrench"] == sensor["wrench"]
        assert got["header"]["frame_id"] == "wrist_frame"


def test_interface_names_publish_the_named_axes_and_nan_for_the_others() -> None:
    yaml = YAML.replace("sensor_name: ft", "interface_names:\n      force:\n        z: ft/force.z")
    with (
        Session(RIG, sensors=SENSORS, controllers=yaml, seed=3) as session,
        connect(session.url) as client,
    ):
        broadcast = client.subscribe("/ft_broadcaster/wrench")
        client.step(20)
        client.sync()
    msg = broadcast.messages[-1]["wrench"]
    assert msg["force"]["z"] == pytest.approx(-2.0 * G, rel=0.05)
    for part, axis in (("force", "x"), ("force", "y"), ("torque", "x"), ("torque", "z")):
        value = msg[part][axis]
        assert value is None or math.isnan(value)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("sensor_name: ft", "sensor_name: nowhere"),
        ("    frame_id: wrist_frame\n", ""),
        ("sensor_name: ft", "sensor_name: ft\n    interface_names.force.x: ft/force.x"),
    ],
)
def test_a_bad_configuration_is_one_line_naming_the_fault(change: str, message: str) -> None:
    yaml = YAML.replace(change, message)
    with pytest.raises(ControllersConfigError) as info:
        Session(RIG, sensors=SENSORS, controllers=yaml).close()
    text = str(info.value)
    assert "\n" not in text
    assert "ft_broadcaster" in text
    assert any(k in text for k in ("no state interface 'nowhere/force.x'", "frame_id", "not both"))
