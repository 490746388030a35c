"""The send side of :class:`~harness.rosbridge.BridgeServer` (mixed into it): each
connection's frames batched for one write while its socket keeps up (fast path), else held in
a bounded queue (slow path) that a writer task moves to the socket as it drains. Subscription
frames beyond their ``queue_length`` are dropped oldest first, counted in
:class:`ConnectionMetrics` and reported to the client as a ``warning`` status; a client whose
backlog exceeds ``send_queue_bytes``, or the slowest clients when every queue together
exceeds ``max_queued_bytes``, are closed (WebSocket status 1008)."""

from __future__ import annotations

import asyncio
import collections
import struct
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed
from websockets.frames import Opcode
from websockets.protocol import State

from harness.rosbridge.outgoing import OutgoingFrame
from harness.rosbridge.protocol import Bridge

__all__ = [
    "ConnectionMetrics",
    "Entry",
    "Peer",
    "SendOps",
    "frame_head",
    "write_batch",
    "write_frames",
]


@dataclass
class ConnectionMetrics:
    """Counters of one connection: frames received, sent, dropped (per topic)."""

    received: int = 0
    sent: int = 0
    dropped: dict[str, int] = field(default_factory=dict)


class Entry:
    """One frame in a peer's queue: ``key``, its subscription's topic (None: an answer,
    never dropped); ``alive`` turns False when it is dropped."""

    __slots__ = ("alive", "data", "key")

    def __init__(self, data: str | bytes, key: str | None) -> None:
        self.data = data
        self.key = key
        self.alive = True


class Peer:
    """One WebSocket client: its frames batched for the next write (fast path) and its
    bounded queue (slow path, while the socket is backed up)."""

    def __init__(self, cid: int, ws: ServerConnection) -> None:
        self.cid = cid
        self.ws = ws
        self.queue: collections.deque[Entry] = collections.deque()
        self.by_key: dict[str, collections.deque[Entry]] = {}
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


def write_frames(peer: Peer, frames: list[str | bytes]) -> None:
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


def write_batch(peer: Peer) -> None:
    """Write the frames batched for ``peer`` (the fast path's one write)."""
    batch, peer.batch, peer.batch_bytes = peer.batch, [], 0
    write_frames(peer, batch)


class SendOps:
    """Sending the bridge's outputs to the server's peers (see the module docstring)."""

    bridge: Bridge
    queued_bytes: int
    send_queue_bytes: int
    max_queued_bytes: int
    closed: dict[str, int]
    _peers: dict[int, Peer]
    _batched: list[Peer]
    _writing: bool
    _loop: asyncio.AbstractEventLoop | None
    _closers: set[asyncio.Future[None]]

    if TYPE_CHECKING:

        def _take_deadlines(self) -> None: ...

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

    def _dispatch(self, outputs: list[OutgoingFrame]) -> None:
        peers = self._peers
        for out in outputs:
            peer = peers.get(out.connection)
            if peer is not None:
                self._enqueue(peer, out)

    def _enqueue(self, peer: Peer, out: OutgoingFrame) -> None:
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
        entry = Entry(out.data, out.name if out.queue_limit else None)
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

    def _forget_queue(self, peer: Peer) -> None:
        self.queued_bytes -= peer.bytes
        peer.queue.clear()
        peer.by_key.clear()
        peer.bytes = 0

    def _overflow(self, peer: Peer, reason: str) -> None:
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

    def _drop(self, peer: Peer, entry: Entry) -> None:
        entry.alive = False
        peer.bytes -= len(entry.data)
        self.queued_bytes -= len(entry.data)
        assert entry.key is not None
        peer.metrics.dropped[entry.key] = peer.metrics.dropped.get(entry.key, 0) + 1
        peer.unreported[entry.key] = peer.unreported.get(entry.key, 0) + 1

    def _write_batches(self) -> None:
        batched, self._batched = self._batched, []
        for peer in batched:
            write_batch(peer)

    async def _write(self, peer: Peer) -> None:
        """Slow path: the socket is backed up; move queued frames to it as it drains."""
        ws = peer.ws
        while True:
            if peer.batch:  # frames batched before the queue started go first
                write_batch(peer)
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
            write_frames(peer, frames)
            try:
                await ws.send(last)  # written after the others; waits while backed up
            except ConnectionClosed:
                return
            peer.metrics.sent += 1
