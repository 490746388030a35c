"""Fork equivalence for the demo arm with a trajectory goal in flight at the fork: a session
resumed at step k and fed the parent's incoming frames from k records the parent's states and
frames from k bit for bit; the child recording names its parent, replays on its own and
``harness diff`` finds nothing (or, after an edit, the first divergence after the fork)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from harness import Session
from harness.cli import main
from harness.recording import Recording
from harness.replay import diff
from harness.resume import META_EDITS, META_PARENT, META_PARENT_SHA256, META_STEP, file_sha256

from .conftest import ARM_FORK, ARM_STEPS, TARGET, feed, frames_from, incoming_after, states


def test_resumed_arm_fed_the_parents_frames_records_the_parents_run(
    arm_parent: Path, tmp_path: Path
) -> None:
    child = tmp_path / "child.mcap"
    with Session.resume(arm_parent, step=ARM_FORK, record_to=child) as session:
        assert session.step_index == ARM_FORK
        assert session.clock == "lockstep"
        # the recorded client is a ghost peer: open in the core, no socket
        assert session.core.bridge is not None
        assert session.core.bridge.connections == [1]
        feed(session, incoming_after(arm_parent, ARM_FORK), ARM_STEPS)
    parent_states = states(arm_parent, ARM_FORK)
    child_states = states(child, ARM_FORK)
    assert len(parent_states) == ARM_STEPS - ARM_FORK + 1
    assert child_states == parent_states  # bit for bit, from the fork to the end
    assert frames_from(child, ARM_FORK) == frames_from(arm_parent, ARM_FORK)
    # the goal in flight at the fork ended, its result recorded for the ghost peer
    with Recording(child) as rec:
        results = [
            json.loads(f.text)
            for f in rec.bridge_frames(ARM_FORK)
            if f.direction == 1 and f.op == "action_result"
        ]
        metadata = rec.metadata
    assert [r["status"] for r in results] == [4]  # SUCCEEDED
    assert metadata[META_PARENT] == arm_parent.name
    assert metadata[META_PARENT_SHA256] == file_sha256(arm_parent)
    assert metadata[META_STEP] == str(ARM_FORK)
    assert json.loads(metadata[META_EDITS]) == []
    # the child keeps the parent's step numbers and replays on its own, prefix included
    assert states(child) == states(arm_parent)
    assert main(["replay", str(child), "--level", "full"]) == 0
    assert main(["diff", str(arm_parent), str(child)]) == 0


def test_a_live_client_takes_over_and_the_goal_in_flight_finishes(
    arm_parent: Path, tmp_path: Path
) -> None:
    from harness.testing import connect

    child = tmp_path / "live.mcap"
    with Session.resume(arm_parent, step=ARM_FORK, record_to=child) as session:
        with connect(session.url) as client:
            description = client.subscribe("/robot_description", "std_msgs/msg/String")
            static = client.subscribe("/tf_static", "tf2_msgs/msg/TFMessage")
            assert client.step(0) == ARM_FORK * session.dt_ns  # paused at the fork
            # the latched topics published at step 0 of the re-derived run reach a late client
            assert "<robot" in description.messages[0]["data"]
            assert static.messages[0]["transforms"]
            client.step(400)
            state = client.state()
            assert session.clients_seen == 1  # the live client, not the ghost
        assert session.core.bridge is not None
        assert session.core.bridge.opened == 2  # the live client came after the ghost
    positions = dict(
        zip(state["joint_state"]["name"], state["joint_state"]["position"], strict=True)
    )
    for joint, target in zip([f"joint{i}" for i in range(1, 8)], TARGET, strict=True):
        assert positions[joint] == pytest.approx(target, abs=0.01)
    with Recording(child) as rec:
        out = [f for f in rec.bridge_frames(ARM_FORK) if f.direction == 1]
    results = [f for f in out if f.op == "action_result"]
    assert [f.connection for f in results] == [1]  # to the ghost peer: recorded, not sent
    assert {f.connection for f in out} == {1, 2}
    # the same states as the parent's until the live client's stepping differs in nothing:
    # its 400 steps (no command) are the parent's 400 steps after the fork
    assert states(child, ARM_FORK) == {
        k: v for k, v in states(arm_parent, ARM_FORK).items() if k <= ARM_FORK + 400
    }
    assert main(["replay", str(child), "--level", "full"]) == 0


def test_an_edit_at_the_fork_shows_as_the_first_divergence_after_it(
    arm_parent: Path, tmp_path: Path
) -> None:
    child = tmp_path / "edited.mcap"
    with Session.resume(
        arm_parent, step=ARM_FORK, record_to=child, edits=["joint.joint1=0.0"]
    ) as session:
        feed(session, incoming_after(arm_parent, ARM_FORK), ARM_STEPS)
    with Recording(child) as rec:
        assert json.loads(rec.metadata[META_EDITS]) == [
            {"kind": "joint", "target": "joint1", "value": [0.0]}
        ]
    report = diff(arm_parent, child)
    assert not report.same
    first = report.first_divergence
    assert first is not None
    assert first.step == ARM_FORK + 1, report.format()
    assert first.cause is not None
    assert "incoming frame" in first.cause.format()
    assert main(["diff", str(arm_parent), str(child)]) == 1
    assert main(["replay", str(child), "--level", "full"]) == 0


@pytest.mark.parametrize("fork", [0, ARM_STEPS])
def test_resumed_at_either_end_and_fed_the_rest_is_the_parents_run(
    arm_parent: Path, tmp_path: Path, fork: int
) -> None:
    """Step 0 (before any client: no ghost) and the last step (the client's goal done, its
    connection still open until the boundary after it)."""
    child = tmp_path / "child.mcap"
    with Session.resume(arm_parent, step=fork, record_to=child) as session:
        assert session.core.bridge is not None
        assert session.core.bridge.connections == ([] if fork == 0 else [1])
        feed(session, incoming_after(arm_parent, fork), ARM_STEPS)
    assert states(child) == states(arm_parent)
    assert frames_from(child, 0) == frames_from(arm_parent, 0)
