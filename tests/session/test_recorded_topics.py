"""What the recording keeps of /joint_states, /tf and /clock (CDR laid out once per run) is
byte for byte what the message a subscriber gets serialises to, on real robots at random
states: an arm, a mobile manipulator on a floating base, and a world of two robots (frame
prefixes)."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pytest

from harness.models import RobotSpec, load_robot, load_world
from harness.recording.convert import from_rosbridge
from harness.recording.layout import typestore
from harness.recording.templates import clock_cdr
from harness.session import Session
from harness.session.channels import (
    joint_state_arrays,
    joint_state_cdr,
    joint_state_message,
    joint_state_of,
)
from harness.session.topics import clock_msg
from tests.models.paths import robots_dir


def _serialised(msgtype: str, msg: dict[str, object]) -> bytes:
    store = typestore()
    return bytes(store.serialize_cdr(from_rosbridge(store, msgtype, msg, where="test"), msgtype))


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
                assert joint_state_cdr(now, channels, arrays) == expected
                assert joint_state_message(now, channels, arrays) == joint_state_of(sim, channels)
            for _, _, tree in core._tf_trees:
                msg = tree.message(tree.moving, sim.link_poses(), t)
                relative = partial(tree.moving_poses, sim.body_poses)
                assert tree.moving_message(relative, t) == msg
                got = tree.moving_cdr(relative, t)
                assert got == _serialised("tf2_msgs/msg/TFMessage", msg)
                count += len(msg["transforms"])
            assert clock_cdr(t) == _serialised("rosgraph_msgs/msg/Clock", clock_msg(t))
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
    robot = load_robot(robots_dir() / relative, cache_dir=tmp_path, base=base)
    with Session(robot) as session:
        assert _compare(session, 1) > 0


def test_recorded_cdr_equals_the_published_message_in_a_world(tmp_path: Path) -> None:
    ur5 = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    world = load_world(
        [
            RobotSpec(ur5, namespace="left", pose=[0.0, -0.6, 0.0]),
            RobotSpec("demo", namespace="right", pose=[0.0, 0.6, 0.0]),
        ],
        cache_dir=tmp_path,
    )
    with Session(robots=world) as session:
        assert _compare(session, 2) > 0
