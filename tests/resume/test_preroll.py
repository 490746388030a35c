"""``--preroll``: a client attaching to a resumed session gets the recorded messages of the
seconds before the step on each topic it subscribes to, before any live message; a ghost
peer and a session without preroll get nothing of the kind."""

from __future__ import annotations

from pathlib import Path

from harness import Session
from harness.resume import preroll_frames
from harness.testing import connect

from .conftest import ARM_FORK


def _stamps(messages: list[dict]) -> list[int]:
    return [m["header"]["stamp"]["sec"] * 10**9 + m["header"]["stamp"]["nanosec"] for m in messages]


def test_a_client_attaching_gets_the_seconds_before_the_step(arm_parent: Path) -> None:
    with (
        Session.resume(arm_parent, step=ARM_FORK, preroll=0.1) as session,
        connect(session.url) as client,
    ):
        joints = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        clock = client.subscribe("/clock", "rosgraph_msgs/msg/Clock")
        client.sync()  # answered after everything sent before it
        before = list(joints.messages), list(clock.messages)
        client.step(10)
        after = list(joints.messages)
    dt = session.dt_ns
    # 100 Hz joint states: steps 250, 255, ..., 300 (0.1 s up to the fork, both ends)
    assert _stamps(before[0]) == [s * dt for s in range(ARM_FORK - 50, ARM_FORK + 1, 5)]
    assert [c["clock"]["nanosec"] for c in before[1]][-1] == ARM_FORK * dt
    # then the live run: step 305, 310 after the fork
    assert _stamps(after[len(before[0]) :]) == [(ARM_FORK + 5) * dt, (ARM_FORK + 10) * dt]


def test_without_preroll_nothing_is_played(arm_parent: Path) -> None:
    with Session.resume(arm_parent, step=ARM_FORK) as session, connect(session.url) as client:
        joints = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        client.sync()
        assert joints.messages == []
    frames = preroll_frames(arm_parent, ARM_FORK, 0.0)
    assert len(frames["/joint_states"]) == 1  # the step itself
