"""Sensors in real sessions: no OpenGL without cameras, identical streams in two processes,
lockstep rates in simulation time."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from harness.session import Session
from tests.sensors.sensor_helpers import RIG

PROBE = """
import json, sys
from harness.session import Session
from harness.sensors import contexts_created
sensors = json.loads(sys.argv[2])
with Session(sys.argv[1], sensors=sensors, record_to=sys.argv[3]) as s:
    s.step(60)
gl = sorted(m for m in ("mujoco.egl", "mujoco.osmesa", "OpenGL.GL") if m in sys.modules)
print(json.dumps({"contexts": contexts_created(), "gl_modules": gl}))
"""


def _probe(robot: str, sensors: list[dict], record_to: Path) -> dict:
    # a fresh process as a user starts it (earlier tests here may have chosen a GL platform)
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, robot, json.dumps(sensors), str(record_to)],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    result: dict = json.loads(proc.stdout.splitlines()[-1])
    return result


@pytest.mark.slow
def test_a_session_without_sensors_never_initialises_gl(tmp_path: Path) -> None:
    assert _probe("demo", [], tmp_path / "a.mcap") == {"contexts": 0, "gl_modules": []}
    # a camera does start it (so the probe above could have failed)
    camera = {"name": "c", "type": "camera", "parent": "mount", "width": 16, "height": 12}
    with_camera = _probe(str(RIG), [camera], tmp_path / "b.mcap")
    assert with_camera["contexts"] == 1
    assert "OpenGL.GL" in with_camera["gl_modules"]


STREAM = """
import hashlib, sys
from harness.recording import Recording
from harness.session import Session
sensors = [
    {"name": "cam", "type": "rgbd", "parent": "mount", "width": 32, "height": 24,
     "update_rate": 50},
    {"name": "scan", "type": "lidar", "parent": "mount", "samples": 90, "noise_stddev": 0.01},
    {"name": "imu", "type": "imu", "parent": "mount", "noise_stddev": 0.05},
    {"name": "ft", "type": "force_torque", "joint": "wrist", "noise_stddev": 0.1},
]
with Session(sys.argv[1], sensors=sensors, seed=11, record_to=sys.argv[2]) as s:
    s.command("swing", position=0.4)
    s.step(100)
digest = hashlib.sha256()
count = 0
with Recording(sys.argv[2]) as rec:
    topics = [t for t in rec.topics if t.split("/")[1] in ("cam", "scan", "imu", "ft")]
    for m in rec.messages(topics):
        digest.update(m.topic.encode() + m.data)
        count += 1
print(count, digest.hexdigest())
"""


@pytest.mark.slow
def test_two_processes_give_byte_identical_sensor_streams(tmp_path: Path) -> None:
    outs = []
    for i in range(2):
        proc = subprocess.run(
            [sys.executable, "-c", STREAM, str(RIG), str(tmp_path / f"run{i}.mcap")],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        outs.append(proc.stdout.split())
    assert outs[0] == outs[1]
    # steps 0..100 of 2 ms: camera 50 Hz: 11 x 4 outputs, scan 10 Hz: 3, imu/ft 100 Hz: 21
    assert int(outs[0][0]) == 11 * 4 + 3 + 21 + 21


def test_rates_are_in_simulation_time_and_lockstep_safe() -> None:
    sensors = [
        {"name": "imu", "type": "imu", "parent": "mount", "update_rate": 50},
        {"name": "scan", "type": "lidar", "parent": "mount", "samples": 8},
    ]
    with Session(RIG, sensors=sensors) as session:
        stamps: dict[str, list[int]] = {"imu": [], "scan": []}
        bridge = session.core.bridge
        assert bridge is not None
        for name in stamps:
            bridge.subscribe(
                f"/{name}/{'imu' if name == 'imu' else 'scan'}",
                lambda m, name=name: stamps[name].append(
                    m.msg["header"]["stamp"]["sec"] * 10**9 + m.msg["header"]["stamp"]["nanosec"]
                ),
            )
        session.step(250)  # 0.5 s
    assert stamps["imu"] == [k * 20_000_000 for k in range(1, 26)]
    assert stamps["scan"] == [k * 100_000_000 for k in range(1, 6)]


NO_BACKEND = """
import sys
from harness.sensors import RenderBackendError
from harness.session import Session
camera = [{"name": "c", "type": "camera", "parent": "mount", "width": 16, "height": 12}]
try:
    with Session(sys.argv[1], sensors=camera, record_to=sys.argv[2]) as s:
        s.step(1)
except RenderBackendError as exc:
    print("ERROR", exc)
"""


@pytest.mark.slow
def test_no_offscreen_gl_is_a_clear_error_naming_the_packages(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "PYOPENGL_PLATFORM"}
    env["MUJOCO_GL"] = "egl"  # the only back-end allowed...
    env["__EGL_VENDOR_LIBRARY_FILENAMES"] = str(tmp_path / "none.json")  # ...and no EGL driver
    proc = subprocess.run(
        [sys.executable, "-c", NO_BACKEND, str(RIG), str(tmp_path / "x.mcap")],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    lines = [line for line in proc.stdout.splitlines() if line.startswith("ERROR")]
    assert lines, proc.stdout + proc.stderr
    assert "no offscreen OpenGL for camera sensors (egl:" in lines[0]
    assert "libegl-mesa0" in lines[0]
    assert "libosmesa6" in lines[0]
