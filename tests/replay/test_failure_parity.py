"""Live stepping and the ``--level full`` replay fail the same way: a logger that raises at
step N stops the live run at N (the exception is raised, later steps are refused), and the
replay of that recording stops at N with the same error; without the failing logger the
replay reports that the recorded run failed there and the re-run did not. A subscriber that
raises stops the run the same way."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest
from websockets.sync.client import connect

from harness.events import StepContext
from harness.events.events import Event
from harness.replay.pipeline import replay_pipeline
from harness.session import Session, SessionClosedError

FAIL_AT = 7


class BreaksAt:
    """A logger whose ``observe`` raises at one step (a bug in a user's logger)."""

    name = "breaks"
    period_ns = 0

    def __init__(self, step: int) -> None:
        self.step = step
        self.observed = 0

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        self.observed += 1
        if ctx.step == self.step:
            raise RuntimeError(f"logger broke at step {ctx.step}")
        return []

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        return []


@pytest.fixture(scope="module")
def failed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("failure") / "run.mcap"
    logger = BreaksAt(FAIL_AT)
    with Session(record_to=path, loggers=[logger]) as session:
        with pytest.raises(RuntimeError, match=f"logger broke at step {FAIL_AT}"):
            session.step(3 * FAIL_AT)
        assert session.step_index == FAIL_AT
        assert isinstance(session.failure, RuntimeError)
        with pytest.raises(SessionClosedError, match=f"logger broke at step {FAIL_AT}"):
            session.step(1)
        assert session.step_index == FAIL_AT
    assert logger.observed == FAIL_AT
    return path


def test_the_replay_with_the_same_logger_fails_at_the_same_step(failed_run: Path) -> None:
    logger = BreaksAt(FAIL_AT)
    report = replay_pipeline(failed_run, loggers=[logger])
    assert report.reproduced, report.format()
    assert report.steps == FAIL_AT
    assert logger.observed == FAIL_AT
    assert report.failure == f"step {FAIL_AT}: RuntimeError: logger broke at step {FAIL_AT}"
    assert f"the run failed at step {FAIL_AT}" in report.format()


def test_a_replay_that_does_not_fail_where_the_run_did_is_a_divergence(failed_run: Path) -> None:
    report = replay_pipeline(failed_run)  # without the failing logger
    assert not report.reproduced
    mismatch = report.mismatch
    assert mismatch is not None, report.format()
    assert (mismatch.kind, mismatch.step) == ("failure", FAIL_AT), report.format()
    assert mismatch.expected == f"step {FAIL_AT}: logger broke at step {FAIL_AT}"
    assert mismatch.actual == "ran on"
    assert report.failure == ""


def test_a_subscriber_that_raises_stops_the_run_and_the_replay_reports_it(tmp_path: Path) -> None:
    """A bug in an in-process subscriber does not escape into the transport: the run stops
    with it (as a failing step does) and the replay, which lacks that subscriber, says the
    recorded run failed there."""
    path = tmp_path / "subscriber.mcap"
    string = "std_msgs/msg/String"

    def broken(msg: Mapping[str, Any], connection: int) -> None:
        raise RuntimeError(f"subscriber broke on {msg['data']!r}")

    with Session(record_to=path) as session, connect(session.url) as client:
        session.call(lambda: session.core.graph.subscribe("/chatter", string, broken))
        client.send(json.dumps({"op": "advertise", "topic": "/chatter", "type": string}))
        client.send(json.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": "x"}}))
        client.send(json.dumps({"op": "call_service", "service": "/rosapi/topics", "id": "t"}))
        answer = json.loads(client.recv(timeout=30))  # frames are processed in order
        assert (answer["op"], answer["result"]) == ("service_response", True)
        assert isinstance(session.failure, RuntimeError)
        with pytest.raises(SessionClosedError, match="subscriber broke on 'x'"):
            session.step(1)
        assert session.step_index == 0
    report = replay_pipeline(path)
    mismatch = report.mismatch
    assert mismatch is not None, report.format()
    assert (mismatch.kind, mismatch.step) == ("failure", 0), report.format()
    assert mismatch.expected == "step 0: subscriber broke on 'x'"
