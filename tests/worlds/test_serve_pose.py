"""A robot placed where its Gazebo launch puts it (``pose=``, ``harness serve --pose``), and
its sensor topics on the graph from the start (issue 33)."""

from __future__ import annotations

import argparse
import math
import warnings

import pytest

from harness.session import Session
from harness.session.live._cli import add_arguments
from harness.testing import connect
from tests.worlds.realworld import TB3_MODELS

BURGER = TB3_MODELS / "turtlebot3_burger" / "model.sdf"


def test_pose_places_the_robot_and_sensor_topics_are_advertised_at_the_start() -> None:
    """x y z roll pitch yaw as ``ros_gz_sim create -x -y -z -R -P -Y``; before any step (no
    sensor has published) /rosapi/topics lists the lidar's /scan and the IMU's /imu."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = Session(BURGER, pose=[1.0, 2.0, 0.01, 0.0, 0.0, 0.5], clock="lockstep")
    with session, connect(session.url) as client:
        qpos = session.sim.data.qpos
        assert (float(qpos[0]), float(qpos[1])) == pytest.approx((1.0, 2.0))
        w, z = float(qpos[3]), float(qpos[6])
        assert 2 * math.atan2(z, w) == pytest.approx(0.5)
        assert session.step_index == 0
        topics = client.call_service("/rosapi/topics")["topics"]
    assert {"/scan", "/imu"} <= set(topics)


def test_serve_pose_takes_three_or_six_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser(prog="harness serve")
    add_arguments(parser)
    assert parser.parse_args(["--pose", "-2", "-0.5", "0.01"]).pose == [-2.0, -0.5, 0.01]
    six = parser.parse_args(["--pose", "1", "2", "0", "0", "0", "1.57"]).pose
    assert six == [1.0, 2.0, 0.0, 0.0, 0.0, 1.57]
    assert parser.parse_args([]).pose is None
    with pytest.raises(SystemExit) as exit_info:
        parser.parse_args(["--pose", "1", "2"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--pose" in error
    assert "X Y Z or X Y Z ROLL PITCH YAW" in error
