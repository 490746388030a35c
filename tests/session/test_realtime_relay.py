"""A realtime clock waiting for its next step applies the input it reads at once (it waits at
the boundary where that input takes effect anyway): a message relayed between two clients
is not held for up to a step, and is recorded at the step it would have been otherwise."""

from __future__ import annotations

from pathlib import Path

from harness.models import LoadedRobot
from harness.recording import Recording
from harness.session import Session
from tests.session.session_helpers import Client


def test_a_relayed_message_does_not_wait_for_the_next_step(
    demo_position: LoadedRobot, tmp_path: Path
) -> None:
    # rate 1e-4: a 2 ms step every 20 s of wall time; the clients' frames (10 s timeout
    # each) could not be answered if they waited for a step boundary
    path = tmp_path / "relay.mcap"
    with Session(demo_position, clock="realtime", rate=1e-4, record_to=path) as session:
        talker, listener = Client(session.url), Client(session.url)
        talker.send({"op": "advertise", "topic": "/chat", "type": "std_msgs/msg/String"})
        listener.subscribe("/chat", "std_msgs/msg/String")
        listener.call("/rosapi/topics")  # its subscription is in
        talker.call("/rosapi/topics")  # and the advertisement
        before = session.step_index
        talker.publish("/chat", {"data": "hello"})
        got = listener.recv_until(lambda f: f.get("op") == "publish" and f["topic"] == "/chat")
        assert got["msg"] == {"data": "hello"}
        after = session.step_index
        talker.close()
        listener.close()
    assert after == before  # no step was waited for
    with Recording(path) as rec:
        relayed = [f for f in rec.bridge_frames() if f.op == "publish" and f.topic == "/chat"]
    assert [f.direction for f in relayed] == [0, 1]  # in, out
    # the frame in takes effect at the next step, the frame out leaves at this one
    assert (relayed[0].step, relayed[1].step) == (before + 1, before)
