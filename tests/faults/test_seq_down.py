"""The Seq endpoint down: the run is not held up by the network (close returns within its
deadline although every request would hang for 30 s), and the drop count is exact
(delivered + dropped == emitted; delivered == what the server acknowledged)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from harness.events import CollectingSink, JointLogger, SeqSink
from harness.session import Session


class _Counting(BaseHTTPRequestHandler):
    lines = 0
    lock = threading.Lock()

    def do_POST(self) -> None:
        body = self.rfile.read(int(self.headers["Content-Length"]))
        with _Counting.lock:
            _Counting.lines += body.count(b"\n")
        self.send_response(201)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, format: str, *args: object) -> None:
        pass


@pytest.fixture
def hanging_endpoint() -> Iterator[str]:
    """Accepts TCP connections and never answers (the worst kind of down)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(64)
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"


def _joint_logger(session: Session) -> JointLogger:
    return JointLogger(session.model, rate_hz=100)


@pytest.mark.timeout(60)
def test_hanging_seq_endpoint_does_not_hold_the_run(hanging_endpoint: str) -> None:
    seq = SeqSink(hanging_endpoint, request_timeout_s=30.0, close_timeout_s=0.5, linger_s=0.01)
    collect = CollectingSink()
    session = Session("demo", loggers=[_joint_logger], sinks=[seq, collect])
    try:
        assert session.step(1000) == 1000
    finally:
        start = time.monotonic()
        session.close()
        closing = time.monotonic() - start
    assert closing < 10.0  # bounded by close_timeout_s, not by the 30 s request timeout
    report = next(r for r in session.sink_reports if r.name == "seq")
    emitted = len(collect.events)
    assert emitted >= 100
    assert report.delivered == 0
    assert report.dropped == emitted


@pytest.mark.timeout(60)
def test_seq_endpoint_going_down_mid_run() -> None:
    server = ThreadingHTTPServer(("127.0.0.1", 0), _Counting)
    _Counting.lines = 0
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    url = f"http://127.0.0.1:{server.server_address[1]}"
    seq = SeqSink(url, close_timeout_s=1.0, linger_s=0.01, retries=1, backoff_s=0.05)
    collect = CollectingSink()
    with Session("demo", loggers=[_joint_logger], sinks=[seq, collect]) as session:
        session.step(500)
        first = len(collect.events)
        deadline = time.monotonic() + 20
        while _Counting.lines < first and time.monotonic() < deadline:
            thread.join(0.01)  # waits on the server thread (it does not end): a short wait
        assert _Counting.lines == first
        server.shutdown()
        server.server_close()
        session.step(500)
    report = next(r for r in session.sink_reports if r.name == "seq")
    emitted = len(collect.events)
    assert emitted > first
    assert report.delivered == _Counting.lines == first
    assert report.dropped == emitted - first
    assert report.note  # names the endpoint and the last error
