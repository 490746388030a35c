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
one write per connection instead of one per frame.
Everything runs on one event loop; call the bridge's in-process API from that loop, then
:meth:`BridgeServer.flush` to send what it produced.

Incoming messages reach the server from the connection's ``data_received`` callback (see
:class:`_Connection`), not through a reader task per connection: a frame is queued (or, in
immediate mode, processed) in the same loop iteration that read it from the socket, and the
answers of a :meth:`BridgeServer.process_pending` leave before it returns. A lockstep client's
request and its answer so cost one loop iteration less each way.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import hmac
import ipaddress
import struct
import time
import urllib.parse
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from http import HTTPStatus
from types import TracebackType
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.frames import DATA_OPCODES, CloseCode, Frame, Opcode
from websockets.http11 import Request, Response
from websockets.protocol import Event, State

from harness.errors import ConfigError
from harness.rosbridge.deadlines import Deadlines
from harness.rosbridge.errors import ExposedServerWarning, FrameError
from harness.rosbridge.limits import MAX_FRAME_BYTES, MAX_QUEUED_BYTES, SEND_QUEUE_BYTES
from harness.rosbridge.protocol import Bridge, Output

__all__ = ["BridgeServer", "ConnectionMetrics", "is_loopback"]

_CLOSE = object()
_TIMEOUT = object()


@dataclass
class ConnectionMetrics:
    """Counters of one connection: frames received, sent, dropped (per topic)."""

    received: int = 0
    sent: int = 0
    dropped: dict[str, int] = field(default_factory=dict)


class _Connection(ServerConnection):
    """A ``websockets`` server connection that hands each complete data message to
    :attr:`on_message` from ``data_received``, instead of queueing it for ``recv()``
    (``serve(create_connection=...)``; everything else, handshake, pings, closing, size
    limits, is the library's). Messages that arrive before the server attaches wait in
    :attr:`early`. Fragmented messages are joined here (the library bounds their total size
    by ``max_size``); a text message that is not UTF-8 fails the connection with 1007, as
    ``recv()`` would."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.on_message: Callable[[str | bytes], None] | None = None
        self.after_read: Callable[[], None] | None = None
        self.early: list[str | bytes] = []
        self._parts = bytearray()
        self._text = False

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if self.after_read is not None:
            self.after_read()

    def eof_received(self) -> None:
        super().eof_received()
        if self.after_read is not None:
            self.after_read()

    def process_event(self, event: Event) -> None:
        if not isinstance(event, Frame) or event.opcode not in DATA_OPCODES:
            super().process_event(event)  # the handshake request, pings, pongs, close
            return
        if event.opcode is not Opcode.CONT:
            self._text = event.opcode is Opcode.TEXT
        if not event.fin:
            self._parts += event.data
            return
        data = bytes(event.data)
        if self._parts:
            data, self._parts = bytes(self._parts + data), bytearray()
        message: str | bytes = data
        if self._text:
            try:
                message = data.decode()
            except UnicodeDecodeError as exc:
                self.set_connection_exc(exc)
                self.protocol.fail(CloseCode.INVALID_DATA, f"{exc.reason} at position {exc.start}")
                self.send_data()
                return
        if self.on_message is None:
            self.early.append(message)
        else:
            self.on_message(message)


class _Entry:
    __slots__ = ("alive", "data", "key")

    def __init__(self, data: str | bytes, key: str | None) -> None:
        self.data = data
        self.key = key
        self.alive = True


class _Peer:
    """One WebSocket client: its frames batched for the next write (fast path) and its
    bounded queue (slow path, while the socket is backed up)."""

    def __init__(self, cid: int, ws: ServerConnection) -> None:
        self.cid = cid
        self.ws = ws
        self.queue: collections.deque[_Entry] = collections.deque()
        self.by_key: dict[str, collections.deque[_Entry]] = {}
        self.bytes = 0
        self.wake = asyncio.Event()
        self.unreported: dict[str, int] = {}
        self.metrics = ConnectionMetrics()
        self.writer: asyncio.Task[None] | None = None
        self.transport = ws.transport
        self.high_water = self.transport.get_write_buffer_limits()[1]
        self.batch: list[str | bytes] = []
        self.batch_bytes = 0
        self.batch_room = 0
        self.paused = False


_HEAD_16 = struct.Struct("!BBH")
_HEAD_64 = struct.Struct("!BBQ")
_FIN_TEXT = 0x80 | Opcode.TEXT.value
_FIN_BINARY = 0x80 | Opcode.BINARY.value


def frame_head(first: int, length: int) -> bytes:
    """The header of an unmasked WebSocket frame (a server's) with first byte ``first``
    (FIN, opcode) and a payload of ``length`` bytes, as ``Frame.serialize`` writes it."""
    if length < 126:
        return bytes((first, length))
    if length < 65536:
        return _HEAD_16.pack(first, 126, length)
    return _HEAD_64.pack(first, 127, length)


def _write_frames(peer: _Peer, frames: list[str | bytes]) -> None:
    """Write ``frames`` to the peer's socket in one write (what ``send`` does per frame)."""
    ws = peer.ws
    if not frames or ws.state is not State.OPEN:
        return  # closing: lost like frames a failed ``send`` could not write
    protocol = ws.protocol
    # Only these frames: the protocol is open and the connection flushes everything else
    # (pongs, close frames) as soon as it is produced.
    parts = protocol.data_to_send()
    if protocol.extensions or protocol.debug or protocol.expect_continuation_frame:
        for data in frames:
            if isinstance(data, str):
                protocol.send_text(data.encode())
            else:
                protocol.send_binary(data)
        parts += protocol.data_to_send()
    else:
        # The bytes protocol.send_text / send_binary would produce (a server's frames are
        # not masked; no extension: compression is off), framed here: a frame object, its
        # checks and a BytesIO per frame cost more than the rest of a relayed frame's send.
        append = parts.append
        for data in frames:
            if isinstance(data, str):
                raw = data.encode()
                append(frame_head(_FIN_TEXT, len(raw)))
            else:
                raw = data
                append(frame_head(_FIN_BINARY, len(raw)))
            append(raw)
    peer.transport.writelines(parts)
    peer.metrics.sent += len(frames)


def _write_batch(peer: _Peer) -> None:
    batch, peer.batch, peer.batch_bytes = peer.batch, [], 0
    _write_frames(peer, batch)


def is_loopback(host: str) -> bool:
    """Whether ``host`` names only this machine (``localhost``, 127.0.0.0/8, ``::1``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _presented_token(request: Request) -> str | None:
    """The token a client presents: ``?token=`` on the URL, else ``Authorization: Bearer``."""
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(request.path).query)
    if query.get("token"):
        return query["token"][0]
    auth = request.headers.get("Authorization", "")
    scheme, _, value = auth.partition(" ")
    return value.strip() if scheme.lower() == "bearer" else None


class BridgeServer:
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
        self._paused: list[_Peer] = []
        self._peers: dict[int, _Peer] = {}
        self._server: Server | None = None
        self._deadlines = Deadlines()
        self._deadline_timer: asyncio.TimerHandle | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._closers: set[asyncio.Future[None]] = set()
        self._batched: list[_Peer] = []
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
            create_connection=_Connection,
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
        presented = _presented_token(request)
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
        assert isinstance(ws, _Connection)
        peer_name = "{}:{}".format(*ws.remote_address[:2]) if ws.remote_address else ""
        cid = self.bridge.connect(peer_name)
        peer = _Peer(cid, ws)
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

    def _receiver(self, peer: _Peer) -> Callable[[str | bytes], None]:
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

    # -- output -------------------------------------------------------------------------

    def flush(self) -> None:
        """Send whatever the bridge produced outside the server's own calls (in-process
        publishes, deferred answers): whoever calls the bridge's in-process API on the
        server's loop calls this after it (the bridge is sans-I/O: nothing wakes the
        server)."""
        outputs = self.bridge.drain()
        if not outputs and not self._batched:  # the common case at a step boundary
            self._take_deadlines()
            return
        self._writing = True  # no write scheduled for later: it happens below
        try:
            self._dispatch(outputs)
            self._take_deadlines()
        finally:
            self._writing = False
            self._write_batches()

    def _dispatch(self, outputs: list[Output]) -> None:
        peers = self._peers
        for out in outputs:
            peer = peers.get(out.connection)
            if peer is not None:
                self._enqueue(peer, out)

    def _enqueue(self, peer: _Peer, out: Output) -> None:
        data = out.data
        if peer.batch:
            # A batch is open (its socket was open and keeping up when it opened; nothing
            # written since): frames join it while it stays within the room it had.
            if peer.batch_bytes <= peer.batch_room:
                peer.batch.append(data)
                peer.batch_bytes += len(data)
                return
        elif not peer.queue and peer.ws.state is State.OPEN:
            room = peer.high_water - peer.transport.get_write_buffer_size()
            if room >= 0:
                # Nothing waits before this frame and the socket keeps up: it goes to the
                # socket as ``send`` would put it there, without the writer task. Frames
                # for one peer produced together are written together (one syscall).
                if not self._batched and not self._writing:
                    assert self._loop is not None  # peers exist only once started
                    self._loop.call_soon(self._write_batches)
                self._batched.append(peer)
                peer.batch_room = room
                peer.batch.append(data)
                peer.batch_bytes += len(data)
                return
        entry = _Entry(out.data, out.name if out.queue_limit else None)
        if out.queue_limit:
            same = peer.by_key.setdefault(out.name, collections.deque())
            while len(same) >= out.queue_limit:
                self._drop(peer, same.popleft())
            same.append(entry)
        peer.queue.append(entry)
        peer.bytes += len(out.data)
        self.queued_bytes += len(out.data)
        if peer.bytes > self.send_queue_bytes and entry.key is not None:
            same = peer.by_key[entry.key]
            while peer.bytes > self.send_queue_bytes and len(same) > 1:
                self._drop(peer, same.popleft())
        if peer.bytes > self.send_queue_bytes:
            self._overflow(peer, "send queue overflow")
            return
        peer.wake.set()
        if self.queued_bytes > self.max_queued_bytes:
            # Every queue together is over the server-wide cap: the slowest clients go.
            for slow in sorted(self._peers.values(), key=lambda p: p.bytes, reverse=True):
                if self.queued_bytes <= self.max_queued_bytes or not slow.bytes:
                    break
                self._overflow(slow, "send queues over the server-wide limit")

    def _forget_queue(self, peer: _Peer) -> None:
        self.queued_bytes -= peer.bytes
        peer.queue.clear()
        peer.by_key.clear()
        peer.bytes = 0

    def _overflow(self, peer: _Peer, reason: str) -> None:
        """Close a client whose unsent frames are over a limit (WebSocket status 1008, the
        reason counted in :attr:`closed`)."""
        self._forget_queue(peer)
        self.closed[reason] = self.closed.get(reason, 0) + 1
        self._peers.pop(peer.cid, None)  # nothing more is queued for it
        self._close_later(peer.ws, 1008, reason)

    def _close_later(self, ws: ServerConnection, code: int = 1000, reason: str = "") -> None:
        # Held until done (an unreferenced task may be collected mid-close), then forgotten.
        closer = asyncio.ensure_future(ws.close(code, reason))
        self._closers.add(closer)
        closer.add_done_callback(self._closers.discard)

    def _drop(self, peer: _Peer, entry: _Entry) -> None:
        entry.alive = False
        peer.bytes -= len(entry.data)
        self.queued_bytes -= len(entry.data)
        assert entry.key is not None
        peer.metrics.dropped[entry.key] = peer.metrics.dropped.get(entry.key, 0) + 1
        peer.unreported[entry.key] = peer.unreported.get(entry.key, 0) + 1

    def _write_batches(self) -> None:
        batched, self._batched = self._batched, []
        for peer in batched:
            _write_batch(peer)

    async def _write(self, peer: _Peer) -> None:
        """Slow path: the socket is backed up; move queued frames to it as it drains."""
        ws = peer.ws
        while True:
            if peer.batch:  # frames batched before the queue started go first
                _write_batch(peer)
            if not peer.queue:
                if peer.unreported:
                    for key, n in sorted(peer.unreported.items()):
                        self.bridge.transport_status(
                            peer.cid,
                            "warning",
                            f"dropped {n} messages on {key}: the client reads slower than "
                            "they are published (raise queue_length to keep more)",
                        )
                    peer.unreported.clear()
                    self.flush()
                    continue
                peer.wake.clear()
                await peer.wake.wait()
                continue
            # Take what fits below the high-water mark (at least one frame): those leave
            # the queue and can no longer be dropped, as if ``send`` had been called on each.
            room = peer.high_water - peer.transport.get_write_buffer_size()
            frames: list[str | bytes] = []
            while peer.queue:
                entry = peer.queue[0]
                if entry.alive and frames and len(entry.data) > room:
                    break
                peer.queue.popleft()
                if not entry.alive:
                    continue
                if entry.key is not None:
                    peer.by_key[entry.key].popleft()
                peer.bytes -= len(entry.data)
                self.queued_bytes -= len(entry.data)
                room -= len(entry.data)
                frames.append(entry.data)
            if not frames:
                continue
            last = frames.pop()
            _write_frames(peer, frames)
            try:
                await ws.send(last)  # written after the others; waits while backed up
            except ConnectionClosed:
                return
            peer.metrics.sent += 1

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
