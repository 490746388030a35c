"""`harness serve --controllers FILE`: the file configures the served robot; a file that does not
fit the robot is one line on stderr and exit code 2."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from harness.testing import connect

DATA = Path(__file__).resolve().parent.parent / "data" / "controllers"
ARM = """
controller_manager:
  ros__parameters:
    update_rate: 250
    arm_controller:
      type: joint_trajectory_controller/JointTrajectoryController
arm_controller:
  ros__parameters:
    joints: [joint1, joint2, joint3]
"""


def _serve(*args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    return subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--port", "0", "--clock", "lockstep", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


@pytest.mark.slow
def test_serve_with_a_controllers_file(tmp_path: Path) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text(ARM)
    proc = _serve("--controllers", str(path))
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert first.startswith("harness serve: ws://127.0.0.1:"), first + proc.stderr.read()
        with connect(first.split()[2]) as client:
            listing = client.call_service("/controller_manager/list_controllers")["controller"]
        assert [(c["name"], c["state"]) for c in listing] == [("arm_controller", "active")]
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err


@pytest.mark.slow
def test_serve_refuses_a_file_for_another_robot() -> None:
    proc = _serve("--controllers", str(DATA / "panda_ros2_controllers.yaml"))
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "panda_ros2_controllers.yaml" in lines[0]
    assert "'panda_joint1' is not a controllable joint" in lines[0]
