"""A Simulation of a world of two robots, and one robot's joints in its own names."""

from __future__ import annotations

import numpy as np
import pytest

from harness.models import RobotSpec, load_robot, load_world
from harness.sim import CommandError, RobotJoints, Simulation


@pytest.fixture(scope="module")
def world():
    return load_world(
        [
            RobotSpec("demo", namespace="a", pose=[0.0, -0.7, 0.0], control="kinematic"),
            RobotSpec("demo", namespace="b", pose=[0.0, 0.7, 0.0], control={"joint2": "velocity"}),
        ],
        scene="empty",
    )


def test_a_world_simulation_addresses_joints_by_prefixed_names(world):
    sim = Simulation(world)
    assert sim.joint_names[:2] == ("a/joint1", "a/joint2")
    assert sim.joint_names[8:10] == ("b/joint1", "b/joint2")
    assert sim.control["a/joint1"] == "kinematic"
    assert sim.control["b/joint2"] == "velocity"
    assert sim.control["b/joint1"] == "position"


def test_robot_joints_read_and_command_in_the_robots_own_names(world):
    sim = Simulation(world)
    b = RobotJoints(sim, world.robot("b").control, "b/")
    assert b.joint_names == tuple(n.removeprefix("b/") for n in sim.joint_names[8:])
    assert b.control["joint2"] == "velocity"
    assert b.owns("b/joint3")
    assert not b.owns("a/joint3")
    notices = b.set_positions({"joint1": 9.0})
    assert [(n.joint, n.kind) for n in notices] == [("joint1", "clamped")]
    b.set_velocities({"joint2": 0.1})
    sim.step()
    commands = sim.joint_commands()
    assert commands[8] == pytest.approx(2.8973)  # b/joint1, clamped
    assert commands[9] == 0.1
    np.testing.assert_array_equal(b.joint_commands(), commands[8:])
    np.testing.assert_array_equal(b.joint_positions(), sim.joint_positions()[8:])
    np.testing.assert_array_equal(b.joint_velocities(), sim.joint_velocities()[8:])
    np.testing.assert_array_equal(b.joint_efforts(), sim.joint_efforts()[8:])
    # The other robot's commands are untouched.
    a = RobotJoints(sim, world.robot("a").control, "a/")
    np.testing.assert_array_equal(a.joint_commands(), a.joint_positions())


def test_robot_joints_refuse_names_of_other_robots_and_change_nothing(world):
    sim = Simulation(world)
    b = RobotJoints(sim, world.robot("b").control, "b/")
    before = sim.joint_commands()
    with pytest.raises(
        CommandError, match=r"unknown joint 'a/joint1' \(controllable joints: joint1"
    ):
        b.set_positions({"joint1": 0.2, "a/joint1": 0.1})
    with pytest.raises(CommandError, match="unknown joint 'b/joint1'"):
        b.command_joint_state(["b/joint1"], [0.1])
    np.testing.assert_array_equal(sim.joint_commands(), before)
    with pytest.raises(CommandError, match=r"joints \['elbow'\] are not controllable"):
        RobotJoints(sim, ["elbow"], "b/")


def test_one_robot_without_prefix_is_the_simulation_itself():
    robot = load_robot("demo")
    sim = Simulation(robot)
    joints = RobotJoints(sim, robot.control)
    assert joints.joint_names == sim.joint_names
    with pytest.raises(CommandError, match="unknown joint 'elbow'"):
        joints.command("elbow", position=0.0)
    joints.command_joint_state(["joint1"], [0.3])
    assert sim.joint_commands()[0] == 0.3
