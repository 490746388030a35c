"""The asyncio rosbridge v2 WebSocket server: a thin I/O loop around :class:`Bridge`.

Two ingestion modes: *immediate* (each frame is processed when it arrives, for standalone
use) and *queued* (``queued=True``: frames, with their connection, wait in arrival order
until the owner calls :meth:`BridgeServer.process_pending` between simulation steps; frames
of several connections interleave in arrival order). Each connection has a bounded send
queue: subscription frames beyond their ``queue_length`` (or the bridge default) are dropped
oldest first, counted in :attr:`BridgeServer.metrics` and reported to the client as a
``warning`` status; a client whose unsendable backlog exceeds ``send_queue_bytes`` is closed.
While a connection's queue is empty and its socket keeps up (write buffer below the
high-water mark), frames skip the queue: those produced together (one
:meth:`BridgeServer.process_pending`, one loop iteration) are framed and written together,
one write per connection instead of one per frame (the send side:
:mod:`harness.rosbridge.sending`, mixed into :class:`BridgeServer`).
Everything runs on one event loop; call the bridge's in-process API from that loop, then
:meth:`BridgeServer.flush` to send what it produced.

Incoming messages reach the server from the connection's ``data_received`` callback (see
:class:`~harness.rosbridge.connection.MessageConnection`), not through a reader task per
connection: a frame is queued (or, in immediate mode, processed) in the same loop iteration
that read it from the socket, and the answers of a :meth:`BridgeServer.process_pending` leave
before it returns. A lockstep client's request and its answer so cost one loop iteration less
each way.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import hmac
import time
import urllib.parse
import warnings
from collections.abc import Callable
from http import HTTPStatus
from types import TracebackType
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.http11 import Request, Response
from websockets.protocol import State

from harness.errors import ConfigError
from harness.rosbridge.connection import MessageConnection, is_loopback, presented_token
from harness.rosbridge.deadlines import Deadlines
from harness.rosbridge.errors import ExposedServerWarning, FrameError
from harness.rosbridge.limits import MAX_FRAME_BYTES, MAX_QUEUED_BYTES, SEND_QUEUE_BYTES
from harness.rosbridge.protocol import Bridge
from harness.rosbridge.sending import ConnectionMetrics, Peer, SendOps

__all__ = ["BridgeServer"]

_CLOSE = object()
_TIMEOUT = object()


class BridgeServer(SendOps):
    """Serve ``bridge`` over WebSocket on ``host:port`` (port 0: any free port, see
    :attr:`url`). ``clock`` returns the ``now_ns`` passed to the bridge in immediate mode
    (default: wall time, for standalone use; the session passes sim time).

    Safe defaults: the server binds the loopback interface unless ``host`` says otherwise
    (then :class:`ExposedServerWarning` is issued at :meth:`start`); frames larger than
    ``max_size`` bytes close their connection (WebSocket close code 1009). With ``token``,
    a client must present it, either as a ``token`` query parameter of the WebSocket URL
    (``ws://host:port/?token=SECRET``: roslibjs ``new Ros({url})``, roslibpy
    ``Ros("ws://host:port/?token=SECRET")``) or as an ``Authorization: Bearer SECRET``
    header (roslibpy ``Ros(host, port, headers=...)``); any other handshake is refused with
    HTTP 401 before a single frame is read. :attr:`url` includes the token."""

    def __init__(
        self,
        bridge: Bridge | None = None,
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        queued: bool = False,
        clock: Callable[[], int] | None = None,
        max_size: int = MAX_FRAME_BYTES,
        ping_interval: float | None = 20.0,
        ping_timeout: float | None = 20.0,
        send_queue_bytes: int = SEND_QUEUE_BYTES,
        max_queued_bytes: int = MAX_QUEUED_BYTES,
        max_pending: int = 100_000,
        token: str | None = None,
    ) -> None:
        if token is not None and not token:
            raise ConfigError("token must be a non-empty string (or None for no token)")
        self.bridge = bridge if bridge is not None else Bridge()
        self.host = host
        self.token = token
        self.port = port
        self.queued = queued
        self.clock = clock if clock is not None else time.time_ns
        self.max_size = max_size
        self.ping_interval = ping_interval
        self.ping_timeout = ping_timeout
        self.send_queue_bytes = send_queue_bytes
        self.max_queued_bytes = max_queued_bytes
        self.queued_bytes = 0
        """Bytes waiting in every connection's send queue together."""
        self.closed: dict[str, int] = {}
        """Connections the server closed, by reason (slow clients over a queue limit)."""
        self.max_pending = max_pending
        self.metrics: dict[int, ConnectionMetrics] = {}
        self.pending_event = asyncio.Event()
        """Set when queued input waits for :meth:`process_pending`."""
        self.on_input: Callable[[], bool] | None = None
        """Queued mode: called at the end of a socket read that queued input (in the
        connection's ``data_received``), before :attr:`pending_event` is set: an owner that
        processes the input at once returns True (the event stays clear: no wake-up, one
        loop iteration less), else False."""
        self._unannounced = False  # input queued by the current read, pending_event not set
        self._pending: collections.deque[tuple[int, Any]] = collections.deque()
        self._paused: list[Peer] = []
        self._peers: dict[int, Peer] = {}
        self._server: Server | None = None
        self._deadlines = Deadlines()
        self._deadline_timer: asyncio.TimerHandle | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._closers: set[asyncio.Future[None]] = set()
        self._batched: list[Peer] = []
        self._writing = False  # in a call that writes the batches before it returns
        self._stopped = False

    # -- lifecycle ----------------------------------------------------------------------

    async def start(self) -> str:
        """Bind and start serving; returns :attr:`url`."""
        self._loop = asyncio.get_running_loop()
        self.bridge.deadlines()  # from now on the bridge keeps the deadlines it starts
        self._stopped = False
        if not is_loopback(self.host):
            warnings.warn(
                f"rosbridge server on {self.host!r}: reachable from other machines "
                f"({'token required' if self.token else 'no token: anyone can drive the robot'})",
                ExposedServerWarning,
                stacklevel=2,
            )
        self._server = await serve(
            self._handle,
            self.host,
            self.port,
            max_size=self.max_size,
            ping_interval=self.ping_interval,
            ping_timeout=self.ping_timeout,
            compression=None,
            process_request=self._check_token if self.token is not None else None,
            create_connection=MessageConnection,
        )
        self.port = self._server.sockets[0].getsockname()[1]
        return self.url

    def _check_token(self, connection: ServerConnection, request: Request) -> Response | None:
        assert self.token is not None
        if len(request.headers.get_all("Authorization")) > 1:
            # Headers.get would raise (HTTP 500 and a traceback per request): refuse plainly.
            return connection.respond(
                HTTPStatus.BAD_REQUEST, "more than one Authorization header\n"
            )
        presented = presented_token(request)
        if presented is not None and hmac.compare_digest(
            presented.encode("utf-8"), self.token.encode("utf-8")
        ):
            return None
        reason = "no token presented" if presented is None else "wrong token"
        return connection.respond(
            HTTPStatus.UNAUTHORIZED,
            f"{reason}: this rosbridge server requires ?token=... on the URL "
            "or an Authorization: Bearer header\n",
        )

    @property
    def url(self) -> str:
        """``ws://host:port`` actually bound (with ``/?token=...`` when a token is
        required: hand it to clients as is)."""
        base = f"ws://{self.host}:{self.port}"
        if self.token is None:
            return base
        return f"{base}/?{urllib.parse.urlencode({'token': self.token})}"

    async def stop(self) -> None:
        """Close every connection and stop listening."""
        if self._deadline_timer is not None:
            self._deadline_timer.cancel()
            self._deadline_timer = None
        self._deadlines = Deadlines()
        self._stopped = True  # deadlines the bridge still reports are not enforced
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
            self._server = None

    async def __aenter__(self) -> BridgeServer:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()

    # -- input --------------------------------------------------------------------------

    async def _handle(self, ws: ServerConnection) -> None:
        assert isinstance(ws, MessageConnection)
        peer_name = "{}:{}".format(*ws.remote_address[:2]) if ws.remote_address else ""
        cid = self.bridge.connect(peer_name)
        peer = Peer(cid, ws)
        self._peers[cid] = peer
        self.metrics[cid] = peer.metrics
        if self.queued:
            self.pending_event.set()  # the owner sees the connection at its next boundary
        peer.writer = asyncio.create_task(self._write(peer))
        try:
            receive = self._receiver(peer)
            early, ws.early = ws.early, []
            for message in early:
                receive(message)
            self._announce()
            ws.on_message = receive
            if self.queued:
                ws.after_read = self._announce
            await ws.wait_closed()
        finally:
            ws.on_message = None
            ws.after_read = None
            if self.queued:
                self._pending.append((cid, _CLOSE))
                self.pending_event.set()
            else:
                self._close(cid)
            peer.writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await peer.writer
            self._forget_queue(peer)

    def _receiver(self, peer: Peer) -> Callable[[str | bytes], None]:
        """What the connection calls with each message it reads (from ``data_received``)."""
        cid, metrics, pending = peer.cid, peer.metrics, self._pending

        def receive_queued(message: str | bytes) -> None:
            metrics.received += 1
            pending.append((cid, message))
            self._unannounced = True  # announced at the end of the read (_announce)
            if len(pending) >= self.max_pending and not peer.paused:
                peer.paused = True  # read no more from it until process_pending drains
                self._paused.append(peer)
                peer.transport.pause_reading()

        def receive_now(message: str | bytes) -> None:
            metrics.received += 1
            self._dispatch(self.bridge.receive(cid, message, self.clock()))
            self._take_deadlines()
            self._write_batches()

        return receive_queued if self.queued else receive_now

    def _announce(self) -> None:
        """After a read: input it queued is processed by the owner now, or waits for it
        (:attr:`pending_event`)."""
        if self._unannounced:
            self._unannounced = False
            if self.on_input is None or not self.on_input():
                self.pending_event.set()

    def _close(self, cid: int) -> None:
        self._peers.pop(cid, None)
        self._dispatch(self.bridge.disconnect(cid))
        self._take_deadlines()

    def process_pending(self, now_ns: int, until: float | None = None) -> int:
        """Queued mode: process every waiting frame (and disconnects, call timeouts) in
        arrival order at sim time ``now_ns``; returns how many frames were processed.

        ``until`` (a :func:`time.monotonic` time) stops early once it has passed, after at
        least one frame: the rest wait, in order, for the next call (a realtime clock keeps
        its step schedule under a flood of frames; the frames wait instead)."""
        count = 0
        self.pending_event.clear()
        pending = self._pending
        self._writing = True  # no write scheduled for later: it happens below
        try:
            while pending:
                cid, item = pending.popleft()
                if item is _CLOSE:
                    self._close(cid)
                elif item is _TIMEOUT:
                    self._dispatch(self.bridge.time_out_call(cid))
                elif cid in self._peers:
                    count += 1
                    self._dispatch(self.bridge.receive(cid, item, now_ns))
                if until is not None and pending and time.monotonic() >= until:
                    self.pending_event.set()  # more to do at the next boundary
                    break
            self._take_deadlines()
            if self._paused and len(pending) < self.max_pending:
                self._resume_reading()
        finally:
            self._writing = False
            self._write_batches()  # the answers leave now, not one loop iteration later
        return count

    def _resume_reading(self) -> None:
        paused, self._paused = self._paused, []
        for peer in paused:
            peer.paused = False
            if peer.ws.state is State.OPEN:
                peer.transport.resume_reading()

    def pending(self) -> list[tuple[int, str | bytes]]:
        """Queued mode: the frames waiting for :meth:`process_pending`, in arrival order."""
        return [(cid, item) for cid, item in self._pending if isinstance(item, (str, bytes))]

    def _take_deadlines(self) -> None:
        """Start and cancel the timers of the deadlines the bridge reports (drained)."""
        for key, timeout_s in self.bridge.deadlines():
            if self._stopped or self._loop is None:
                continue
            if timeout_s is None:
                self._deadlines.cancel(key)
            else:
                self._start_timer(key, timeout_s)

    def _start_timer(self, key: int, timeout_s: float) -> None:
        # One loop timer, for the earliest deadline (see harness.rosbridge.deadlines).
        assert self._loop is not None
        deadline = self._loop.time() + timeout_s
        self._deadlines.add(key, deadline)
        timer = self._deadline_timer
        if timer is None or deadline < timer.when():
            if timer is not None:
                timer.cancel()
            self._deadline_timer = self._loop.call_at(deadline, self._fire_deadlines)

    def _fire_deadlines(self) -> None:
        assert self._loop is not None
        due = self._deadlines.pop_due(self._loop.time())
        earliest = self._deadlines.next_deadline()
        self._deadline_timer = (
            None if earliest is None else self._loop.call_at(earliest, self._fire_deadlines)
        )
        for key in due:
            if self.queued:
                self._pending.append((key, _TIMEOUT))
                self.pending_event.set()
            else:
                self._dispatch(self.bridge.time_out_call(key))
                self._take_deadlines()
                self._write_batches()

    # -- convenience --------------------------------------------------------------------

    def connection_ids(self) -> list[int]:
        """Ids of the open WebSocket connections."""
        return list(self._peers)

    def close_connection(self, connection: int) -> None:
        """Close one client's WebSocket (the bridge forgets it when the socket closes)."""
        peer = self._peers.get(connection)
        if peer is None:
            raise FrameError(f"no open connection {connection}")
        self._close_later(peer.ws)
