"""SeqSink against a local HTTP server implementing Seq's CLEF ingestion contract."""

from __future__ import annotations

import json
import re
import socket
import threading
import time
from datetime import datetime, timezone
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from harness.events import (
    CollisionBegin,
    EventHub,
    JointSample,
    Level,
    LogMessage,
    SeqSink,
)

API_KEY = "test-key-123"
LEVELS = {"Verbose", "Debug", "Information", "Warning", "Error", "Fatal"}
START = datetime(2026, 1, 2, 3, 4, 5, tzinfo=timezone.utc)


class SeqServer:
    """POST /ingest/clef: CLEF lines, X-Seq-ApiKey checked; 201 on success (as Seq)."""

    def __init__(self, fail_first: int = 0) -> None:
        self.requests: list[dict] = []
        self.events: list[dict] = []
        self.problems: list[str] = []
        self.fail_first = fail_first
        owner = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_POST(self):
                body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
                owner.requests.append({"path": self.path, "headers": dict(self.headers)})
                if len(owner.requests) <= owner.fail_first:
                    return self._reply(503)
                if self.path != "/ingest/clef":
                    return self._reply(404)
                if self.headers.get("Content-Type") != "application/vnd.serilog.clef":
                    return self._reply(415)
                if self.headers.get("X-Seq-ApiKey") != API_KEY:
                    return self._reply(401)
                for line in body.decode("utf-8").splitlines():
                    owner.events.append(json.loads(line))
                return self._reply(201)

            def _reply(self, status):
                self.send_response(status)
                self.send_header("Content-Length", "2")
                self.end_headers()
                self.wfile.write(b"{}")

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def seq():
    servers = []

    def make(**kw):
        servers.append(SeqServer(**kw))
        return servers[-1]

    yield make
    for s in servers:
        s.close()


def sample_events(n):
    out = []
    for i in range(n):
        common = {"step": i + 1, "sim_time_ns": (i + 1) * 2_000_000, "robot": "arm"}
        if i % 3 == 0:
            out.append(
                CollisionBegin(
                    **common,
                    body1="hand",
                    body2="box",
                    geom1="hand_geom",
                    geom2="box_geom",
                    penetration=0.001 * i,
                    normal_force=2.5,
                    position=(0.1, 0.2, 0.3),
                    normal=(0.0, 0.0, 1.0),
                )
            )
        elif i % 3 == 1:
            out.append(
                JointSample(
                    **common,
                    joints=("j1", "j2"),
                    positions=(0.1, 0.2),
                    velocities=(0.0, 0.1),
                    efforts=(1.0, 2.0),
                )
            )
        else:
            out.append(
                LogMessage.of(
                    **common,
                    level=Level.WARNING,
                    text=f"message {i} with {{braces}}",
                    fields={"@odd": i, "plain": "x"},
                )
            )
    return out


def check_clef(event: dict) -> None:
    stamp = event["@t"]
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6}Z", stamp), stamp
    datetime.fromisoformat(stamp.replace("Z", "+00:00"))
    assert event["@l"] in LEVELS
    assert ("@mt" in event) != ("@m" in event)
    for key in event:
        if key.startswith("@") and not key.startswith("@@"):
            assert key in {"@t", "@l", "@mt", "@m"}, key
    if "@mt" in event:
        for name in re.findall(r"\{([^{}]+)\}", event["@mt"]):
            assert name in event, f"template names missing property {name}"


def test_every_event_valid_clef_and_batched(seq):
    server = seq()
    sink = SeqSink(server.url, api_key=API_KEY, batch_size=50, start_time=START)
    events = sample_events(300)
    hub = EventHub(sinks=[sink])
    hub.emit(events)
    (report,) = hub.close()
    assert (report.delivered, report.dropped) == (300, 0)
    assert len(server.events) == 300
    assert len(server.requests) < 300 // 10  # batched: at most 50 per request
    assert all(r["path"] == "/ingest/clef" for r in server.requests)
    for sent, got in zip(events, server.events, strict=True):
        check_clef(got)
        assert got["event"] == sent.kind
        assert got["step"] == sent.step
        assert got["sim_time_ns"] == sent.sim_time_ns
        expected_t = START.timestamp() + sent.sim_time_ns / 1e9
        stamp = datetime.fromisoformat(got["@t"].replace("Z", "+00:00")).timestamp()
        assert stamp == pytest.approx(expected_t, abs=1e-6)
    log = server.events[2]
    assert log["@m"] == "message 2 with {braces}"
    assert log["@l"] == "Warning"
    assert log["@@odd"] == 2
    assert log["plain"] == "x"
    assert "@odd" not in log
    assert server.events[1]["positions"] == {"j1": 0.1, "j2": 0.2}
    assert server.events[1]["@l"] == "Debug"
    assert server.events[0]["@l"] == "Information"


def test_wrong_api_key_is_counted_as_dropped(seq):
    server = seq()
    sink = SeqSink(server.url, api_key="wrong", batch_size=40, backoff_s=0.01)
    for event in sample_events(100):
        sink.emit(event)
    report = sink.close()
    assert (report.delivered, report.dropped) == (0, 100)
    assert "401" in report.note
    assert server.events == []
    assert len(server.requests) <= 100 // 40 + 1  # a 401 is not retried


def test_transient_failures_are_retried(seq):
    server = seq(fail_first=2)
    sink = SeqSink(server.url, api_key=API_KEY, backoff_s=0.01, retries=3)
    for event in sample_events(10):
        sink.emit(event)
    report = sink.close()
    assert (report.delivered, report.dropped) == (10, 0)
    assert len(server.events) == 10
    assert len(server.requests) >= 3


def closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_server_down_finishes_within_the_deadline_with_exact_drops():
    sink = SeqSink(
        f"http://127.0.0.1:{closed_port()}", retries=50, backoff_s=0.05, close_timeout_s=0.5
    )
    for event in sample_events(123):
        sink.emit(event)
    start = time.monotonic()
    report = sink.close()
    elapsed = time.monotonic() - start
    assert (report.delivered, report.dropped) == (0, 123)
    assert elapsed < 3.0  # the deadline (0.5 s) bounds close, not 50 retries with backoff
    assert "Connection" in report.note or "refused" in report.note


def test_unresponsive_server_never_blocks_emit_and_close_keeps_its_deadline():
    # accepts TCP connections (kernel backlog) but never answers
    hole = socket.socket()
    hole.bind(("127.0.0.1", 0))
    hole.listen(64)
    try:
        url = f"http://127.0.0.1:{hole.getsockname()[1]}"
        sink = SeqSink(url, queue_size=10, request_timeout_s=60.0, close_timeout_s=0.5)
        for event in sample_events(1000):  # far more than the queue holds: dropped, not waited on
            sink.emit(event)
        start = time.monotonic()
        report = sink.close()
        elapsed = time.monotonic() - start
    finally:
        hole.close()
    assert (report.delivered, report.dropped) == (0, 1000)
    assert elapsed < 5.0  # not the 60 s request timeout
    assert sink.close() is report
