"""Fork equivalence for the mobile robot: a diff drive mid-turn and a noisy lidar. Resumed at
a step inside the turn and fed the parent's /cmd_vel frames from there, the child records the
parent's states, frames and every message (the lidar's noise stream, odometry, /tf) from the
fork on, bit for bit."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.cli import main
from harness.models.mobile import MOBILE_CONTROLLERS, load_mobile_bot
from harness.recording import Recording
from harness.testing import connect

from .conftest import feed, frames_from, incoming_after, messages_from, states

TWIST = "geometry_msgs/msg/Twist"
LIDAR = {"name": "scan", "type": "lidar", "parent": "base_link", "samples": 45,
         "noise_stddev": 0.01}  # fmt: skip
DRIVE = ((0.2, 0.0, 20), (0.0, 1.0, 16), (0.2, 0.0, 10))
MID_TURN = 20 + 20 * 25 + 8 * 25  # 8 of the turn's 16 commands given
STEPS = 20 + sum(n for _, _, n in DRIVE) * 25


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {
        "linear": {"x": linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": angular},
    }


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("mobile") / "drive.mcap"
    session = Session(
        load_mobile_bot(), controllers=MOBILE_CONTROLLERS, sensors=[LIDAR], seed=7,
        record_to=path,
    )  # fmt: skip
    with session, connect(session.url) as client:
        client.step(20)
        for linear, angular, n in DRIVE:
            for _ in range(n):
                client.publish("/cmd_vel", TWIST, _twist(linear, angular))
                client.step(25)
    return path


def test_resumed_mid_turn_records_the_parents_drive_and_scans(drive: Path, tmp_path: Path) -> None:
    child = tmp_path / "child.mcap"
    with Session.resume(drive, step=MID_TURN, record_to=child) as session:
        odom = session.core.sim.data.qvel.copy()
        assert abs(odom).max() > 0.1  # the base is turning at the fork
        feed(session, incoming_after(drive, MID_TURN), STEPS)
    assert states(child, MID_TURN) == states(drive, MID_TURN)
    assert len(states(child, MID_TURN)) == STEPS - MID_TURN + 1
    assert frames_from(child, MID_TURN) == frames_from(drive, MID_TURN)
    parent, resumed = messages_from(drive, MID_TURN), messages_from(child, MID_TURN)
    scans = [t for t in parent if t.endswith("scan")]
    assert scans
    assert all(len(parent[t]) >= 3 for t in scans)  # noisy scans after the fork
    for topic in parent:
        assert resumed[topic] == parent[topic], topic
    assert main(["replay", str(child), "--level", "full"]) == 0


def test_a_noise_edit_changes_the_scans_not_the_drive(drive: Path, tmp_path: Path) -> None:
    child = tmp_path / "quiet.mcap"
    with Session.resume(drive, step=MID_TURN, record_to=child, edits=["noise.scan=0"]) as session:
        feed(session, incoming_after(drive, MID_TURN), STEPS)
    assert states(child, MID_TURN) == states(drive, MID_TURN)  # sensors do not move the robot
    parent, quiet = messages_from(drive, MID_TURN), messages_from(child, MID_TURN)
    assert [t for t, _ in quiet["/scan/scan"]] == [t for t, _ in parent["/scan/scan"]]
    assert all(
        a != b for (_, a), (_, b) in zip(quiet["/scan/scan"], parent["/scan/scan"], strict=True)
    )
    assert quiet["/scan"] == parent["/scan"]  # the robot's own lidar keeps its noise
    assert main(["replay", str(child), "--level", "full"]) == 0


def test_a_slower_turn_at_the_fork(drive: Path, tmp_path: Path) -> None:
    """A diff drive's limit changed mid-turn: the base turns less from the fork on; the run
    up to the fork is the parent's and the child replays with the edit."""
    child = tmp_path / "slow.mcap"
    edit = "param.diff_drive_controller.angular.z.max_velocity=0.2"
    with Session.resume(drive, step=MID_TURN, record_to=child, edits=[edit]) as session:
        feed(session, incoming_after(drive, MID_TURN), STEPS)
    parent, slow = states(drive), states(child)
    assert {k: v for k, v in slow.items() if k <= MID_TURN} == {
        k: v for k, v in parent.items() if k <= MID_TURN
    }
    assert slow[STEPS] != parent[STEPS]
    with Recording(drive) as a, Recording(child) as b:
        yaw_parent = _yaw(next(iter(a.physics_states(STEPS, STEPS + 1))).qpos)
        yaw_slow = _yaw(next(iter(b.physics_states(STEPS, STEPS + 1))).qpos)
    assert abs(yaw_slow) < abs(yaw_parent)  # 8 x 25 steps at 0.2 rad/s, not 1 rad/s
    assert main(["replay", str(child), "--level", "full"]) == 0


def _yaw(qpos: Any) -> float:
    """The floating base's heading from its free joint quaternion (w, x, y, z at 3:7)."""
    w, x, y, z = (float(v) for v in qpos[3:7])
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
