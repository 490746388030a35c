"""``imu_sensor_broadcaster/IMUSensorBroadcaster``: a controller fed by a sensor's state
interfaces, added as one module of the controllers room (nothing else names it)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from harness.controllers import ControllersConfigError
from harness.replay.pipeline import replay_pipeline
from harness.session import Session
from harness.testing import connect
from tests.sensors.sensor_helpers import RIG

ROOT = Path(__file__).resolve().parents[2]
TYPE = "imu_sensor_broadcaster/IMUSensorBroadcaster"
YAML = f"""
controller_manager:
  ros__parameters:
    update_rate: 100
    imu_broadcaster:
      type: {TYPE}
imu_broadcaster:
  ros__parameters:
    sensor_name: imu
    frame_id: imu_link
    static_covariance_angular_velocity: [0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5]
"""
# an IMU on the swinging weight of the rig, with noise: every reading differs
SENSORS = [{"name": "imu", "type": "imu", "parent": "weight", "noise_stddev": 0.05}]
FIELDS = ("orientation", "angular_velocity", "linear_acceleration")


def _ns(msg: dict) -> int:
    stamp = msg["header"]["stamp"]
    return int(stamp["sec"]) * 1_000_000_000 + int(stamp["nanosec"])


def test_a_client_receives_what_the_imu_measures_at_that_step(tmp_path: Path) -> None:
    path = tmp_path / "imu.mcap"
    with (
        Session(RIG, sensors=SENSORS, controllers=YAML, seed=3, record_to=path) as session,
        connect(session.url) as client,
    ):
        broadcast = client.subscribe("/imu_broadcaster/imu")
        measured = client.subscribe("/imu/imu")
        controllers = client.call_service("/controller_manager/list_controllers")
        session.command("swing", position=0.6)
        client.step(60)
        client.sync()
    (entry,) = controllers["controller"]
    assert (entry["name"], entry["type"], entry["state"]) == ("imu_broadcaster", TYPE, "active")
    assert entry["required_state_interfaces"][:4] == [
        "imu/orientation.x", "imu/orientation.y", "imu/orientation.z", "imu/orientation.w",
    ]  # fmt: skip
    by_stamp = {_ns(m): m for m in measured.messages}
    pairs = [(m, by_stamp[_ns(m)]) for m in broadcast.messages if _ns(m) in by_stamp]
    assert len(pairs) >= 10  # 100 Hz sensor and controller on a 500 Hz simulation
    moving = {m["angular_velocity"]["x"] for m, _ in pairs}
    assert len(moving) == len(pairs)  # the weight swings: no two readings alike
    for got, imu in pairs:
        for field in FIELDS:
            assert got[field] == imu[field], (field, _ns(got))
        assert got["header"]["frame_id"] == "imu_link"
        assert got["angular_velocity_covariance"] == [0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5]
        assert got["orientation_covariance"] == [0.0] * 9
    # the controller's frames are recorded and replay bit for bit
    report = replay_pipeline(path)
    assert report.reproduced, report.format()


def test_a_sensor_name_without_imu_interfaces_is_one_line_naming_the_known_ones() -> None:
    wrong = YAML.replace("sensor_name: imu", "sensor_name: ft")
    sensors = [*SENSORS, {"name": "ft", "type": "force_torque", "joint": "wrist"}]
    with pytest.raises(ControllersConfigError) as info:
        Session(RIG, sensors=sensors, controllers=wrong)
    text = str(info.value)
    assert "\n" not in text
    assert "'imu_broadcaster'" in text
    assert "no state interface 'ft/orientation.x'" in text
    assert "imu/linear_acceleration.z" in text  # the interfaces the robot has


def test_the_new_controller_is_one_module_no_other_file_names() -> None:
    # it registers itself: a fresh interpreter finds it without importing it by name
    probe = (
        "import json, sys\n"
        "from harness.controllers import known_types\n"
        "before = 'harness.controllers.imu_sensor_broadcaster' in sys.modules\n"
        f"print(json.dumps([before, {TYPE!r} in known_types()]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=120,
        env={"PYTHONPATH": str(ROOT), "PATH": ""},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == [False, True]
    importers = [
        str(p.relative_to(ROOT))
        for p in (ROOT / "harness").rglob("*.py")
        if re.search(r"^\s*(from|import) .*imu_sensor_broadcaster", p.read_text("utf-8"), re.M)
    ]
    assert importers == []
