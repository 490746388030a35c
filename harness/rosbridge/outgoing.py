"""Outgoing frames of the rosbridge protocol (a room of :class:`~harness.rosbridge.Bridge`,
mixed into it): every frame out is numbered, kept for :meth:`~OutgoingOps.frames` (with
``keep_frames``), charged to its client's send budget when it is a subscription's
(:mod:`harness.rosbridge.budget`), cut into ``fragment`` frames above the client's
``fragment_size``, and put in the outbox its owner takes with :meth:`~OutgoingOps.drain`;
``status`` frames obey the client's ``set_level``. Also rosbridge's ``png`` compression."""

from __future__ import annotations

import base64
import math
import struct
import zlib
from typing import Any, Final, NamedTuple

from harness.rosbridge.budget import BudgetOps
from harness.rosbridge.convert import dumps
from harness.rosbridge.frames import LEVELS

__all__ = [
    "DIRECTION_IN",
    "DIRECTION_OUT",
    "OutgoingFrame",
    "OutgoingOps",
    "TapRecord",
    "png_frame",
]

DIRECTION_IN: Final = 0
DIRECTION_OUT: Final = 1


class OutgoingFrame(NamedTuple):
    """One frame to send: ``queue_limit`` > 0 marks a subscription frame the server may drop
    (oldest first, per ``(connection, name)``) when the client reads too slowly."""

    connection: int
    data: str | bytes
    op: str
    name: str
    queue_limit: int = 0


class TapRecord(NamedTuple):
    """A frame that crossed the bridge (:meth:`Bridge.frames`): ``direction`` is
    :data:`DIRECTION_IN` or :data:`DIRECTION_OUT`; ``seq`` counts every frame of the bridge
    from 0; ``now_ns``: the bridge's time when it crossed."""

    seq: int
    connection: int
    direction: int
    data: str | bytes
    op: str
    name: str
    now_ns: int = 0


def png_frame(text: str) -> str:
    """rosbridge's png compression: the UTF-8 bytes as an RGB image padded with newlines."""
    raw = text.encode("utf-8")
    width = max(1, math.floor(math.sqrt(len(raw) / 3.0)))
    height = max(1, math.ceil(len(raw) / 3.0 / width))
    raw += b"\n" * (width * height * 3 - len(raw))
    rows = b"".join(b"\x00" + raw[r * width * 3 : (r + 1) * width * 3] for r in range(height))

    def chunk(tag: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(tag + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", crc)

    png = (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )
    return base64.b64encode(png).decode("ascii")


class OutgoingOps(BudgetOps):
    """Numbering, tapping, fragmenting and queueing the frames the bridge sends."""

    _frames: list[TapRecord] | None
    _seq: int
    _outbox: list[OutgoingFrame]

    def drain(self) -> list[OutgoingFrame]:
        """Every output produced so far and not yet taken."""
        out, self._outbox = self._outbox, []
        return out

    def frames(self) -> list[TapRecord]:
        """Every frame in and out since the last call, in order (drained; kept only with
        ``keep_frames``): what a recording of the bridge holds."""
        out, self._frames = self._frames, None if self._frames is None else []
        return [] if out is None else out

    @property
    def seq(self) -> int:
        """The sequence number the next frame gets."""
        return self._seq

    def _tap(self, connection: int, direction: int, data: str | bytes, op: str, name: str) -> None:
        if self._frames is not None:
            self._frames.append(
                TapRecord(self._seq, connection, direction, data, op, name, self._now_ns)
            )
        self._seq += 1

    def _emit(
        self, connection: int, data: str | bytes, op: str, name: str, queue_limit: int = 0
    ) -> None:
        conn = self._conns.get(connection)
        if conn is None:
            return
        if queue_limit and conn.budget is not None:  # a subscription's frame (see OutgoingFrame)
            self._charge(conn, conn.budget, len(data), self._now_ns)
        if self._frames is None:
            self._seq += 1  # what _tap does when no frames are kept
        else:
            self._tap(connection, DIRECTION_OUT, data, op, name)
        self._outbox.append(OutgoingFrame(connection, data, op, name, queue_limit))

    def _send(
        self,
        connection: int,
        text: str,
        op: str,
        name: str,
        frag_id: Any = None,
        fragment_size: int | None = None,
        queue_limit: int = 0,
    ) -> None:
        conn = self._conns.get(connection)
        if conn is None:
            return
        size = fragment_size if fragment_size is not None else conn.fragment_size
        if size is None or len(text) <= size:
            self._emit(connection, text, op, name, queue_limit)
            return
        if frag_id is None:
            conn.fragment_count += 1
            frag_id = f"fragment:{conn.fragment_count}"
        chunks = [text[i : i + size] for i in range(0, len(text), size)]
        for num, chunk in enumerate(chunks):
            frame = dumps(
                {"op": "fragment", "id": frag_id, "data": chunk, "num": num, "total": len(chunks)}
            )
            self._emit(connection, frame, "fragment", name, queue_limit)

    def status(self, connection: int, level: str, msg: str, id: Any = None) -> None:
        """Send a ``status`` frame if the connection's ``set_level`` lets ``level`` through."""
        conn = self._conns.get(connection)
        if conn is None or LEVELS[level] < conn.level:
            return
        frame: dict[str, Any] = {"op": "status", "level": level, "msg": msg}
        if id is not None:
            frame["id"] = id
        self._emit(connection, dumps(frame), "status", "")

    def transport_status(self, connection: int, level: str, msg: str) -> None:
        """A ``status`` the transport sends by itself (not an answer to a frame: frames
        dropped for a slow reader, a client-mode link lost), subject to ``set_level``."""
        self.status(connection, level, msg)
