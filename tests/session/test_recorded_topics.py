"""What the recording keeps of /joint_states, /tf and /clock (the records the core hands the
recorder, their CDR laid out once per set of names) is byte for byte what the message a
subscriber gets serialises to, on real robots at random states: an arm, a mobile manipulator
on a floating base, and a world of two robots (frame prefixes). The /tf transforms (posed from
the joints where one joint moves a link) equal those from the bodies' world poses to
rounding."""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from harness.models import RobotSpec, load_robot, load_world
from harness.recording import ClockRecord
from harness.recording.convert import from_rosbridge
from harness.recording.layout import typestore
from harness.session import Session
from harness.session.core.channels import (
    joint_state_arrays,
    joint_state_message,
    joint_state_of,
    joint_state_record,
)
from harness.session.core.topics import clock_msg
from tests.models.paths import robots_dir


def _serialised(msgtype: str, msg: dict[str, object]) -> bytes:
    store = typestore()
    return bytes(store.serialize_cdr(from_rosbridge(store, msgtype, msg, where="test"), msgtype))


def _assert_close(got: dict[str, Any], expected: dict[str, Any]) -> None:
    assert len(got["transforms"]) == len(expected["transforms"])
    for a, b in zip(got["transforms"], expected["transforms"], strict=True):
        assert (a["header"], a["child_frame_id"]) == (b["header"], b["child_frame_id"])
        for part in ("translation", "rotation"):
            x, y = a["transform"][part], b["transform"][part]
            assert x.keys() == y.keys()
            assert all(abs(x[k] - y[k]) < 1e-12 for k in x), (a["child_frame_id"], x, y)


def _compare(session: Session, seed: int) -> int:
    """Random states of the session's simulation: CDR vs the subscriber's message each time;
    the number of /tf transforms compared."""
    core = session.core
    sim = core.sim
    rng = np.random.default_rng(seed)

    def check() -> int:
        count = 0
        for k in range(5):
            sim.data.qpos[:] += rng.normal(0.0, 0.3, sim.model.nq)
            sim.data.qvel[:] = rng.normal(0.0, 1.0, sim.model.nv)
            t = 1_234_567_891 * (k + 1)
            for channels in core.robots:
                expected = _serialised("sensor_msgs/msg/JointState", joint_state_of(sim, channels))
                now = sim.sim_time_ns  # joint_state_of stamps the simulation's time
                arrays = partial(joint_state_arrays, sim, channels)
                # views where the joints are consecutive: the same values as gathering them
                data, dof = sim.data, channels.js_dadr
                effort = np.where(channels.js_kin, data.qfrc_applied[dof], data.qfrc_actuator[dof])
                for got, want in zip(
                    arrays(), (data.qpos[channels.js_qadr], data.qvel[dof], effort), strict=True
                ):
                    np.testing.assert_array_equal(got, want)
                assert joint_state_record(now, channels, arrays).cdr() == expected
                assert joint_state_message(now, channels, arrays) == joint_state_of(sim, channels)
            for _, _, tree in core._tf_trees:
                relative = partial(tree.moving_poses, sim.data.qpos, sim.body_poses)
                msg = tree.moving_message(relative, t)
                # the same transforms as from the bodies' world poses (to rounding)
                _assert_close(msg, tree.message(tree.moving, sim.link_poses(), t))
                got = tree.moving_record(relative, t).cdr()
                assert got == _serialised("tf2_msgs/msg/TFMessage", msg)
                count += len(msg["transforms"])
            assert ClockRecord(t).cdr() == _serialised("rosgraph_msgs/msg/Clock", clock_msg(t))
        return count

    return session.call(check)


@pytest.mark.parametrize(
    ("relative", "base"),
    [
        ("panda_description/urdf/panda.urdf", "fixed"),
        ("tiago_description/robots/tiago.urdf", "floating"),
    ],
)
def test_recorded_cdr_equals_the_published_message(
    relative: str, base: str, tmp_path: Path
) -> None:
    # hulls: what is compared is the topics; tiago's concave link meshes would take minutes
    # to decompose in this fresh cache
    robot = load_robot(
        robots_dir() / relative, cache_dir=tmp_path, base=base, mesh_collision="hull"
    )
    with Session(robot, mesh_collision="hull") as session:
        assert _compare(session, 1) > 0


def test_recorded_cdr_equals_the_published_message_in_a_world(tmp_path: Path) -> None:
    ur5 = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    world = load_world(
        [
            RobotSpec(ur5, namespace="left", pose=[0.0, -0.6, 0.0]),
            RobotSpec("demo", namespace="right", pose=[0.0, 0.6, 0.0]),
        ],
        cache_dir=tmp_path,
        mesh_collision="hull",
    )
    with Session(robots=world, mesh_collision="hull") as session:
        assert _compare(session, 2) > 0


@pytest.mark.parametrize(
    "control",
    [
        "kinematic",  # every joint kinematic: efforts from qfrc_applied
        {"panda_joint2": "kinematic", "panda_joint5": "kinematic"},  # mixed: per joint
    ],
)
def test_recorded_joint_states_of_kinematic_joints(control: object, tmp_path: Path) -> None:
    robot = load_robot(
        robots_dir() / "panda_description/urdf/panda.urdf", cache_dir=tmp_path, control=control
    )
    with Session(robot) as session:
        assert _compare(session, 3) > 0


_MJCF = """
<mujoco>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" quat="0.9 0.1 0.2 0.3">
      <joint name="yaw" axis="0 0 1" ref="0.4"/>
      <geom size="0.05"/>
      <body name="arm" pos="0 0 0.2" euler="0.3 0 0">
        <joint name="pitch" axis="0 1 0" pos="0 0 -0.05"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.02"/>
        <body name="tool" pos="0 0 0.2">
          <geom size="0.03"/>
          <body name="slider" pos="0.1 0 0" euler="0 0.5 0">
            <joint name="ext" type="slide" axis="1 0 0" ref="0.02" range="-0.1 0.1"/>
            <geom size="0.02"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="yaw" kp="10"/><position joint="pitch" kp="10"/>
    <position joint="ext" kp="10"/>
  </actuator>
</mujoco>
"""


def test_recorded_tf_of_joints_from_the_world_with_references_and_offsets(
    tmp_path: Path,
) -> None:
    """A hinge from the world with a reference angle, a hinge off its body's origin (posed
    from world poses) and a slide with a reference under a body without a joint (fixed to its
    parent: /tf_static): the transforms equal those from world poses."""
    path = tmp_path / "arm.xml"
    path.write_text(_MJCF)
    with Session(load_robot(path)) as session:
        assert _compare(session, 4) == 3 * 5
