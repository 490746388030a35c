"""Velocity joints track their command as Gazebo's velocity interface does, whatever the link's
inertia and the joint's damping, and never with more than the effort limit (issue 34: DiffBot's
wheels, Iyy 3e-5 kg m^2 with damping 0.2, reached 6 % of the command)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness.models import load_robot

URDF = """<robot name="spinner">
  <link name="base"/>
  <joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/>
    <axis xyz="0 0 1"/><dynamics damping="{damping}"/><limit effort="{effort}" velocity="10"/>
  </joint>
  <link name="wheel"><inertial><mass value="1"/>
    <inertia ixx="{inertia}" iyy="{inertia}" izz="{inertia}" ixy="0" ixz="0" iyz="0"/>
  </inertial></link>
</robot>"""
COMMAND = 1.0  # rad/s
# 100 N m accelerates the drive (link + rotor inertia, 1 kg m^2 at most) at 100 rad/s^2 or more:
# 1 rad/s within 0.01 s; 0.1 s leaves room for the last, unsaturated steps
SETTLE_STEPS = 50


def _spinner(tmp_path: Path, inertia: float, damping: float, effort: float) -> mujoco.MjModel:
    path = tmp_path / "spinner.urdf"
    path.write_text(URDF.format(inertia=inertia, damping=damping, effort=effort))
    return load_robot(path, control="velocity", scene="empty", repair_inertia=False).model


def _run(model: mujoco.MjModel, steps: int, load: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    data = mujoco.MjData(model)
    data.ctrl[0] = COMMAND
    data.qfrc_applied[0] = load
    speed, force = np.empty(steps), np.empty(steps)
    for k in range(steps):
        mujoco.mj_step(model, data)
        speed[k], force[k] = data.qvel[0], data.qfrc_actuator[0]
    assert sum(w.number for w in data.warning) == 0
    return speed, force


@pytest.mark.parametrize("damping", [0.0, 0.2, 1.0])
@pytest.mark.parametrize("inertia", [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0])
def test_the_joint_reaches_the_command_whatever_its_inertia_and_damping(
    tmp_path: Path, inertia: float, damping: float
) -> None:
    """Within 0.1 s the joint runs at the command to 0.1 % and stays there, without overshoot
    (before: 0.25 % of the command at 1e-6 kg m^2 with damping 0.2, 33 % at 1e-3 with 1.0)."""
    model = _spinner(tmp_path, inertia, damping, effort=100.0)
    speed, force = _run(model, 500)
    assert np.abs(speed[SETTLE_STEPS:] - COMMAND).max() <= 1e-3 * COMMAND
    assert speed.max() <= COMMAND * (1 + 1e-3)
    assert np.abs(force).max() <= 100.0 + 1e-9


@pytest.mark.parametrize("inertia", [1e-6, 1e-3])
def test_a_load_within_the_effort_limit_costs_little_speed(tmp_path: Path, inertia: float) -> None:
    """A constant 5 N m against the joint (a twentieth of its effort limit), as a dragging
    caster or a slope loads a wheel: the drive loses at most 0.2 rad/s at its full effort, so
    0.01 here (before: 5 N m stalled the light joints, whose kv was inertia / timestep; a
    1 kg m^2 joint was already this stiff)."""
    model = _spinner(tmp_path, inertia, damping=0.2, effort=100.0)
    speed, _ = _run(model, 500, load=-5.0)
    assert np.abs(speed[-100:] - COMMAND).max() <= 0.01 + 1e-9


@pytest.mark.parametrize("inertia", [1e-6, 1e-3, 1.0])
def test_the_effort_limit_still_bounds_the_drive(tmp_path: Path, inertia: float) -> None:
    """A 0.05 N m drive against damping 0.1: never more than 0.05 N m, so it can hold no more
    than 0.5 rad/s (the damping's torque at that speed is the whole effort), and it gets there
    without ringing between the limits."""
    model = _spinner(tmp_path, inertia, damping=0.1, effort=0.05)
    speed, force = _run(model, 2500)
    assert np.abs(force).max() <= 0.05 + 1e-12
    assert speed.max() <= 0.5 + 1e-6
    assert speed.min() >= 0.0
    if inertia < 1.0:  # the heaviest needs longer than 5 s (its time constant is 40 s)
        assert speed[-1] == pytest.approx(0.5, rel=0.01)
