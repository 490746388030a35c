"""Fragmented messages (rosbridge's ``fragment`` op): pieces collected per connection and
message id, bounded in count and bytes, reassembled and processed as one frame; and the
floor on the ``fragment_size`` a client asks for its outgoing frames (a room of
:class:`~harness.rosbridge.Bridge`, mixed into it)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from harness.rosbridge.errors import FrameError
from harness.rosbridge.frames import BridgeHost, Connection, field_of

__all__ = ["FragmentOps"]


class FragmentOps(BridgeHost):
    """The ``fragment`` op: ``max_fragmented_messages`` incomplete messages and
    ``max_fragment_bytes`` of pieces per connection at most; outgoing fragments of
    ``min_fragment_size`` characters at least."""

    max_fragment_bytes: int
    max_fragmented_messages: int
    min_fragment_size: int

    def _fragment_floor(self, c: int, op: str, size: int, msg_id: Any) -> int:
        """The ``fragment_size`` to apply for a client's asked ``size`` (> 0): at least
        ``min_fragment_size``; a smaller one is raised, with a ``warning`` status saying so
        (a fragment per character costs a frame, its recording and its send per character)."""
        floor = self.min_fragment_size
        if size >= floor:
            return size
        self.status(
            c,
            "warning",
            f"{op}: fragment_size {size} is below the minimum {floor}; raised to {floor}",
            msg_id,
        )
        return floor

    def _op_fragment(self, c: int, obj: Mapping[str, Any]) -> None:
        conn = self._conns[c]
        fid = obj.get("id")
        if fid is None:
            raise FrameError("fragment: Expected a id field but none was found.")
        data = field_of(obj, "fragment", "data", str)
        num = field_of(obj, "fragment", "num", int)
        total = field_of(obj, "fragment", "total", int)
        if total < 1 or not 0 <= num < total:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: num {num} is outside 0..total-1 (total {total}) for id {fid}"
            )
        entry = conn.fragments.get(fid)
        if entry is None:
            if len(conn.fragments) >= self.max_fragmented_messages:
                raise FrameError(
                    f"fragment: more than {self.max_fragmented_messages} "
                    "incomplete fragmented messages"
                )
            entry = conn.fragments[fid] = (total, {})
        if entry[0] != total:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: total {total} differs from {entry[0]} for id {fid}; message dropped"
            )
        if conn.fragment_bytes + len(data) > self.max_fragment_bytes:
            self._forget_fragments(conn, fid)
            raise FrameError(
                f"fragment: fragmented messages exceed {self.max_fragment_bytes} bytes; "
                f"id {fid} dropped"
            )
        old = entry[1].get(num)
        conn.fragment_bytes += len(data) - (len(old) if old is not None else 0)
        entry[1][num] = data
        if len(entry[1]) < total:
            return
        self._forget_fragments(conn, fid)
        text = "".join(entry[1][i] for i in range(total))
        objects, error = self._split(text)
        for inner in objects:
            self._process(c, inner)
        if error is not None:
            raise FrameError(f"fragment: reassembled message {fid} is not valid: {error}")

    @staticmethod
    def _forget_fragments(conn: Connection, fid: Any) -> None:
        entry = conn.fragments.pop(fid, None)
        if entry is not None:
            conn.fragment_bytes -= sum(len(d) for d in entry[1].values())
