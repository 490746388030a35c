"""The odometry messages of the mobile-base controllers (diff drive, steering), built only when
published since issue 36's speed work, are what they were: every message of a run, read after
the whole run (so each must hold the values of its own update), pinned bit for bit to what the
controllers gave before (a digest of the transcript)."""

from __future__ import annotations

import hashlib
import json
from typing import Any

import pytest

from .test_diff_drive import IdealWheels, _twist
from .test_diff_drive import _controller as _diff_drive
from .test_steering_controllers import ACKERMANN, IdealJoints, _build, _reference

PINNED = {
    # main at 16c044b
    "diff_drive": "1b39d990557d4f75ac4703fb4f679ad8d111d442ab237b41e32474bcef46ff48",
    "ackermann": "648b4e31e77990ddd8c316bf405a534912209e7b16173479830f1afb7554a51a",
}


def _transcript(published: list[Any]) -> str:
    text = json.dumps([[p.topic, p.type, p.msg] for p in published], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _diff_drive_run() -> list[Any]:
    ctrl = _diff_drive(publish_rate=50.0, enable_odom_tf=True)
    wheels = IdealWheels()
    ctrl.activate(wheels.readings())
    ctrl.on_message("~/cmd_vel", _twist(0.4, 0.3), 0, wheels.readings())
    published = wheels.run(ctrl, 1.0)
    ctrl.on_message("~/cmd_vel", _twist(-0.2, -0.5), 0, wheels.readings())
    return published + wheels.run(ctrl, 0.5)


def _ackermann_run() -> list[Any]:
    ctrl = _build(
        ACKERMANN,
        traction_joints_names=["rear_right", "rear_left"],
        steering_joints_names=["front_right", "front_left"],
        wheelbase=0.5, traction_track_width=0.4, steering_track_width=0.4,
        traction_wheels_radius=0.1, pose_covariance_diagonal=[0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
    )  # fmt: skip
    joints = IdealJoints()
    ctrl.activate(joints.readings())
    ctrl.on_message("~/reference", _reference(0.5, 0.4), 0, joints.readings())
    return joints.run(ctrl, 1.0)


@pytest.mark.parametrize("case", sorted(PINNED))
def test_odometry_messages_are_what_they_were(case: str) -> None:
    published = {"diff_drive": _diff_drive_run, "ackermann": _ackermann_run}[case]()
    assert len(published) >= 50
    assert _transcript(published) == PINNED[case]
