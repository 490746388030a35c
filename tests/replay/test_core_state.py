"""The clock's state lives in the session core, not in the live shell (issue 32: "the core's
whole state is reachable from the core"): a start waiting for its first client and a pause
limit are the core's, and a core driven by a recording's incoming frames ends with the clock
state the live run ended with."""

from __future__ import annotations

from pathlib import Path

from harness.models import load_robot
from harness.recording import Recording
from harness.session import CoreOptions, Session, SessionCore
from harness.testing import connect


def test_a_core_fed_the_recorded_frames_ends_with_the_live_clock_state(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    robot = load_robot("demo", control="position")
    with Session(robot, clock="fast", start="on_client", record_to=path) as session:
        session.pause_at(40)
        assert session.call(lambda: session.core.pause_at) == 40  # held by the core
        assert session.call(lambda: session.core.awaiting_client)
        with connect(session.url, lockstep=False):
            assert session.run_until(lambda: session.sim.step_index >= 40, sim_timeout=5.0) == 40
            live = session.call(
                lambda: (
                    session.core.paused,
                    session.core.awaiting_client,
                    session.core.pause_at,
                    session.sim.step_index,
                )
            )
    assert live == (True, False, None, 40)  # started by the client, paused at the limit

    with Recording(path) as rec:
        options = CoreOptions.from_metadata(rec.metadata)
        frames = [f for f in rec.bridge_frames() if f.direction == 0]
    assert [f.topic for f in frames[:2]] == ["harness/python", "harness/python"]  # start, pause
    core = SessionCore(robot, options)
    assert (core.paused, core.awaiting_client, core.pause_at) == (True, True, None)
    core.start()
    core.publish_initial()
    for frame in frames:
        while core.sim.step_index < frame.step - 1:
            core.advance()
        core.replay_frame(frame.connection, frame.op, frame.topic, frame.payload)
    after = (core.paused, core.awaiting_client, core.pause_at, core.sim.step_index)
    assert after == live
    # nothing left for a shell to do: no client start pending, no pause due
    assert not core.start_on_client()
    assert not core.pause_if_due()
