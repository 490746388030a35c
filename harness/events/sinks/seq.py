"""A sink to Seq: CLEF batches over HTTP from a background thread, loss-accounted.

``emit`` only appends to a bounded in-memory queue (a full queue drops the event and counts
it), so the simulation never waits for the network. A worker thread posts batches of
newline-delimited CLEF to ``/ingest/clef`` (``Content-Type: application/vnd.serilog.clef``,
``X-Seq-ApiKey``); connection failures, timeouts, 5xx, 408 and 429 are retried with
exponential backoff, other 4xx (401: wrong API key) are not. ``close`` flushes until its
deadline, then stops waiting: the report counts as delivered exactly the events the server
acknowledged (2xx) and every other emitted event as dropped, so ``delivered + dropped`` always
equals the number of events emitted.

CLEF timestamps (``@t``) are ``start_time + sim_time_ns`` (``start_time``: wall clock at
construction unless given), so Seq orders events as the simulation did; ``step`` and
``sim_time_ns`` are properties too.
"""

from __future__ import annotations

import http.client
import json
import threading
import time
from collections import deque
from datetime import datetime, timezone
from typing import Any
from urllib.parse import urlsplit

from harness.events.errors import LoggerConfigError
from harness.events.events import Event, Level, LogMessage
from harness.events.sinks.base import SinkReport

__all__ = ["CLEF_CONTENT_TYPE", "SeqSink", "clef_url", "to_clef"]

CLEF_CONTENT_TYPE = "application/vnd.serilog.clef"
_SEQ_LEVEL = {
    Level.DEBUG: "Debug",
    Level.INFO: "Information",
    Level.WARNING: "Warning",
    Level.ERROR: "Error",
    Level.FATAL: "Fatal",
}


def clef_url(endpoint: str) -> str:
    """The ingestion URL: ``endpoint`` with ``/ingest/clef`` appended when it has no path."""
    parts = urlsplit(endpoint)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise LoggerConfigError(f"seq sink: endpoint must be an http(s) URL, got {endpoint!r}")
    if parts.path in ("", "/"):
        return endpoint.rstrip("/") + "/ingest/clef"
    return endpoint


def _iso(epoch_ns: int) -> str:
    seconds, ns = divmod(epoch_ns, 1_000_000_000)
    stamp = datetime.fromtimestamp(seconds, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    return f"{stamp}.{ns // 1000:06d}Z"


def to_clef(event: Event, start_ns: int) -> dict[str, Any]:
    """One CLEF object: ``@t`` (``start_ns + sim_time_ns``, ISO-8601 UTC), ``@l``, ``@mt``
    (``@m`` for free-text log messages), then the properties with a leading ``@`` escaped as
    ``@@`` and the event kind as ``event``."""
    out: dict[str, Any] = {"@t": _iso(start_ns + event.sim_time_ns)}
    out["@l"] = _SEQ_LEVEL[event.level]
    if isinstance(event, LogMessage):
        out["@m"] = event.text
    else:
        out["@mt"] = event.TEMPLATE
    out["event"] = event.kind
    for key, value in event.properties().items():
        out["@" + key if key.startswith("@") else key] = value
    return out


def _retryable(status: int) -> bool:
    return status >= 500 or status in (408, 429)


class SeqSink:
    """Batched, non-blocking CLEF sink (see the module docstring for the guarantees).

    ``batch_size``: events per request at most; ``linger_s``: how long the worker waits for a
    batch to fill once an event is queued; ``queue_size``: events held before new ones are
    dropped; ``retries``/``backoff_s``: attempts after the first and the first wait (doubling);
    ``request_timeout_s``: per request; ``close_timeout_s``: the most ``close`` waits.
    """

    name = "seq"

    def __init__(
        self,
        endpoint: str = "http://localhost:5341",
        *,
        api_key: str | None = None,
        batch_size: int = 500,
        linger_s: float = 0.05,
        queue_size: int = 10_000,
        retries: int = 3,
        backoff_s: float = 0.2,
        request_timeout_s: float = 5.0,
        close_timeout_s: float = 5.0,
        start_time: datetime | None = None,
    ) -> None:
        if batch_size < 1 or queue_size < 1 or retries < 0:
            raise LoggerConfigError(
                "seq sink: batch_size and queue_size must be >= 1 and retries >= 0"
            )
        self.url = clef_url(endpoint)
        parts = urlsplit(self.url)
        self._https = parts.scheme == "https"
        self._host = parts.hostname or ""
        self._port = parts.port
        self._path = parts.path + (f"?{parts.query}" if parts.query else "")
        self._headers = {"Content-Type": CLEF_CONTENT_TYPE}
        if api_key:
            self._headers["X-Seq-ApiKey"] = api_key
        self.batch_size = batch_size
        self.linger_s = linger_s
        self.queue_size = queue_size
        self.retries = retries
        self.backoff_s = backoff_s
        self.request_timeout_s = request_timeout_s
        self.close_timeout_s = close_timeout_s
        start = start_time or datetime.now(timezone.utc)
        self._start_ns = round(start.timestamp() * 1e6) * 1000
        self._queue: deque[Event] = deque()
        self._cond = threading.Condition()
        self._emitted = 0
        self._delivered = 0
        self._requests = 0
        self._closing = False
        self._deadline = float("inf")
        self._final = threading.Event()  # set when close has reported: counters frozen
        self._last_error = ""
        self._report: SinkReport | None = None
        self._thread = threading.Thread(target=self._work, name="harness-seq-sink", daemon=True)
        self._thread.start()

    @property
    def requests(self) -> int:
        """HTTP requests made so far (each attempt counts)."""
        return self._requests

    def emit(self, event: Event) -> None:
        """Queue ``event``; when the queue is full it is dropped (and counted), never waited on."""
        with self._cond:
            self._emitted += 1
            if self._closing or len(self._queue) >= self.queue_size:
                return
            self._queue.append(event)
            if len(self._queue) in (1, self.batch_size):
                self._cond.notify()

    def close(self) -> SinkReport:
        """Flush until ``close_timeout_s`` has passed, then report (exact counts)."""
        if self._report is not None:
            return self._report
        with self._cond:
            self._closing = True
            self._deadline = time.monotonic() + self.close_timeout_s
            self._cond.notify_all()
        self._thread.join(max(0.0, self._deadline - time.monotonic()))
        with self._cond:
            self._final.set()
            delivered = self._delivered
            dropped = self._emitted - delivered
            self._queue.clear()
            self._cond.notify_all()
        note = self.url if not self._last_error else f"{self.url}: {self._last_error}"
        self._report = SinkReport(self.name, delivered, dropped, note)
        return self._report

    # -- worker thread ----------------------------------------------------------------

    def _work(self) -> None:
        while True:
            batch = self._take()
            if batch is None:
                return
            self._send(batch)

    def _take(self) -> list[Event] | None:
        with self._cond:
            while not self._queue:
                if self._closing or self._final.is_set():
                    return None
                self._cond.wait()
            if not self._closing and len(self._queue) < self.batch_size:
                until = time.monotonic() + self.linger_s
                while len(self._queue) < self.batch_size and not self._closing:
                    left = until - time.monotonic()
                    if left <= 0:
                        break
                    self._cond.wait(left)
            n = min(len(self._queue), self.batch_size)
            return [self._queue.popleft() for _ in range(n)]

    def _time_left(self) -> float:
        return self._deadline - time.monotonic()

    def _send(self, batch: list[Event]) -> None:
        body = "".join(
            json.dumps(to_clef(e, self._start_ns), separators=(",", ":")) + "\n" for e in batch
        ).encode("utf-8")
        attempt = 0
        while not self._final.is_set():
            timeout = min(self.request_timeout_s, self._time_left())
            if timeout <= 0:
                return
            status, error = self._post(body, timeout)
            if 200 <= status < 300:
                with self._cond:
                    if not self._final.is_set():
                        self._delivered += len(batch)
                return
            self._last_error = error
            if (status and not _retryable(status)) or attempt >= self.retries:
                return  # dropped: close reports emitted - delivered
            wait = min(self.backoff_s * 2**attempt, self._time_left())
            if wait > 0:
                self._final.wait(wait)
            attempt += 1

    def _post(self, body: bytes, timeout: float) -> tuple[int, str]:
        """``(status, error)``; status 0 when no HTTP response came back."""
        self._requests += 1
        cls = http.client.HTTPSConnection if self._https else http.client.HTTPConnection
        conn = cls(self._host, self._port, timeout=timeout)
        try:
            conn.request("POST", self._path, body=body, headers=self._headers)
            response = conn.getresponse()
            response.read()
            status = response.status
            return status, "" if 200 <= status < 300 else f"HTTP {status} {response.reason}"
        except (OSError, http.client.HTTPException) as exc:
            return 0, f"{type(exc).__name__}: {exc}"
        finally:
            conn.close()
