"""Control modes: kinematic tracks exactly, dynamic lags within effort limits, limits clamp or
allow, commands are validated atomically."""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.models import load_robot
from harness.sim import CommandError, Simulation
from harness.sim.metrics import joint_limits


def _sim(arm, mode, **kwargs) -> Simulation:
    return Simulation.from_model(arm.build(mode), control=dict.fromkeys(arm.joints, mode), **kwargs)


def test_kinematic_joints_report_the_command_bit_for_bit(arm):
    sim = _sim(arm, "kinematic")
    follower = sim.model.jnt_qposadr[sim.model.joint("finger_right_joint").id]
    contacts = 0
    for k in range(1100):
        targets = {j: v + 1e-7 * math.sin(k) for j, v in arm.targets(k).items()}
        assert sim.set_positions(targets) == []
        sim.step()
        np.testing.assert_array_equal(sim.joint_positions(), [targets[j] for j in arm.joints])
        # the mimic follower is written by the mimic law (polycoef 0 1: equal)
        assert sim.data.qpos[follower] == targets["finger_left_joint"]
        contacts += sim.contacts().size
    assert contacts > 0
    assert sim.data.xpos[sim.model.body("box").id][1] > 0.05  # it pushed the box, exactly on path


def test_kinematic_velocity_is_the_finite_difference_of_commands(arm):
    sim = _sim(arm, "kinematic")
    sim.command("j1", position=0.01)
    sim.step()
    assert sim.joint_velocities()[0] == 0.01 / sim.dt
    sim.step()  # command held: velocity back to zero, and the input changed
    assert sim.joint_velocities()[0] == 0.0
    assert sim.input_changed
    sim.step()
    assert not sim.input_changed


def test_link_poses_follow_the_kinematic_command(arm):
    sim = _sim(arm, "kinematic")
    sim.set_positions({"j1": 0.3, "j2": 0.2})
    sim.step()
    xyz, quat = sim.link_poses()["link2"]
    # link2 sits 0.2 m above link1 on the yawing axis: unaffected by j2, rotated by j1 and j2
    np.testing.assert_allclose(xyz, [0.0, 0.0, 0.7], atol=1e-12)
    half1, half2 = 0.15, 0.1
    qz = np.array([math.cos(half1), 0, 0, math.sin(half1)])
    qy = np.array([math.cos(half2), 0, math.sin(half2), 0])
    w1, v1 = qz[0], qz[1:]
    w2, v2 = qy[0], qy[1:]
    expected = np.array([w1 * w2 - v1 @ v2, *(w1 * v2 + w2 * v1 + np.cross(v1, v2))])
    np.testing.assert_allclose(quat, expected, atol=1e-12)


def test_position_mode_lags_and_respects_effort_limits(arm):
    model = arm.build("position", kp=3000.0)
    sim = Simulation.from_model(model, control=dict.fromkeys(arm.joints, "position"))
    limits = joint_limits(sim)
    errors, efforts = [], []
    for k in range(1300):
        # the sweep, then a jump that asks for more torque than the joints have
        targets = arm.targets(k) if k < 1100 else {"j1": 0.0, "j2": 1.2, "j3": -1.0}
        sim.set_positions(targets)
        sim.step()
        errors.append(np.abs(sim.joint_positions()[:3] - [targets[j] for j in arm.joints[:3]]))
        efforts.append(np.abs(sim.joint_efforts()))
    err = np.max(errors, axis=0)
    eff = np.max(efforts, axis=0)
    assert err.min() > 1e-3  # a servo lags behind a moving target
    assert np.all(eff <= limits.effort + 1e-9)
    assert np.any(eff >= limits.effort * 0.999)  # the limit was actually reached


def test_demo_position_mode_respects_urdf_effort_limits():
    robot = load_robot("demo", control="position")
    sim = Simulation(robot)
    limits = joint_limits(sim)
    assert limits.effort[0] == 87.0
    assert limits.velocity[0] > 0
    sim.set_positions({"joint1": 1.5, "joint2": 0.5, "joint4": -1.0})
    peak = np.zeros(len(sim.joint_names))
    for _ in range(300):
        sim.step()
        peak = np.maximum(peak, np.abs(sim.joint_efforts()))
    assert np.all(peak <= limits.effort + 1e-9)
    assert peak[0] >= 87.0 * 0.999


def test_dynamic_commands_beyond_limits_clamp_with_a_notice(arm):
    sim = _sim(arm, "position")
    notices = sim.command("j2", position=2.5)
    assert [(n.joint, n.kind, n.requested, n.applied) for n in notices] == [
        ("j2", "clamped", 2.5, 1.7)
    ]
    assert "beyond its limits" in notices[0].message
    sim.step()
    assert sim.data.ctrl[sim.model.actuator("j2").id] == 1.7
    assert sim.last_input is not None
    assert sim.last_input.ctrl[1] == 1.7


def test_velocity_commands_clamp_to_the_urdf_velocity_limit():
    sim = Simulation(load_robot("demo", control="velocity"))
    limit = sim.description.joint("joint1").limits.velocity if sim.description else None
    assert limit
    (notice,) = sim.command("joint1", velocity=10.0)
    assert notice.kind == "clamped"
    assert notice.applied == limit


@pytest.mark.parametrize(("policy", "expected"), [("clamp", 2.8), ("allow", 3.1)])
def test_kinematic_limits_clamp_or_allow(arm, policy, expected):
    sim = _sim(arm, "kinematic", kinematic_limits=policy)
    notices = sim.command("j1", position=3.1)
    assert [n.kind for n in notices] == (["clamped"] if policy == "clamp" else [])
    sim.step()
    assert sim.joint_positions()[0] == expected


def test_field_not_matching_the_mode_is_reported_ignored(arm):
    sim = _sim(arm, "velocity")
    (notice,) = sim.command("j1", position=0.3)
    assert notice.kind == "ignored"
    assert "velocity-controlled" in notice.message
    assert sim.command("j1", position=0.3, velocity=0.2) == []
    assert sim.joint_commands()[0] == 0.2


def test_joint_state_commands_apply_per_index(arm):
    sim = _sim(arm, "position")
    sim.command_joint_state(["j1", "j2", "j3"], position=[0.1, 0.2])
    np.testing.assert_array_equal(sim.joint_commands()[:3], [0.1, 0.2, 0.0])
    with pytest.raises(CommandError, match="3 position values for 2 names"):
        sim.command_joint_state(["j1", "j2"], position=[0.1, 0.2, 0.3])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: s.command("elbow", position=0.1), "unknown joint 'elbow'"),
        (lambda s: s.command("j1", position=math.nan), "joint 'j1': position nan is not finite"),
        (lambda s: s.set_positions({"j1": 0.4, "j2": math.inf}), "position inf is not finite"),
        (lambda s: s.set_positions({"j1": 0.4, "nope": 0.1}), "unknown joint 'nope'"),
        (lambda s: s.set_efforts({"j3": "x"}), "effort 'x' is not a number"),
    ],
)
def test_bad_commands_are_refused_and_change_nothing(arm, call, message):
    sim = _sim(arm, "position")
    sim.step(5)
    state, commands = sim.get_state(), sim.joint_commands()
    with pytest.raises(CommandError, match=message):
        call(sim)
    sim.step()
    np.testing.assert_array_equal(sim.joint_commands(), commands)
    assert not sim.input_changed  # nothing new reached the physics
    assert sim.get_state().shape == state.shape
