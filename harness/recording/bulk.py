"""Bulk decoding of ``harness_msgs/msg/PhysicsState`` messages straight from decompressed
chunks into numpy arrays, with no Python work per message.

Every state of one run has the same layout (one model, one state spec), so its CDR payload
has fixed offsets: ``step`` at 4, ``sim_time_ns`` at 12, ``state_spec`` at 20, the ``state``
length at 24 and its values at 28, then ``qpos`` and ``qvel`` likewise (8-byte aligned
relative to the payload, which starts after the 4-byte encapsulation header). Runs of
equally spaced records are read through strided views of the chunk (one copy per field);
the length fields of every row are checked. Anything else (another layout, big-endian CDR,
rows of different sizes) returns ``None`` and the caller decodes message by message.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from harness.recording.chunks import MESSAGE_HEADER_SIZE, gather
from harness.recording.records import PhysicsStateArrays

__all__ = ["decode_physics_states", "empty_physics_states"]

I64 = npt.NDArray[np.int64]
_CDR_LE = 0x0100  # encapsulation header bytes 00 01 (CDR, little-endian) read as <u2
_MAX_RUNS_PER_CHUNK = 16
"""Above this, a chunk's rows are copied out one by one (irregularly interleaved records)."""


def empty_physics_states() -> PhysicsStateArrays:
    """No states: zero rows."""
    none = np.empty(0, dtype=np.int64)
    rows = np.empty((0, 0), dtype=np.float64)
    return PhysicsStateArrays(none, none.copy(), 0, rows, rows.copy(), rows.copy())


class _Rows:
    """``count`` equally spaced payloads of ``length`` bytes in ``buffer`` from ``offset``."""

    __slots__ = ("buffer", "count", "offset", "stride")

    def __init__(self, buffer: bytes, offset: int, stride: int, count: int) -> None:
        self.buffer, self.offset, self.stride, self.count = buffer, offset, stride, count

    def field(self, at: int, dtype: str, n: int) -> npt.NDArray[np.uint8]:
        """A ``(count, n * itemsize)`` byte view of ``n`` values of ``dtype`` at ``at`` in each
        payload (bytes: rows are rarely 8-byte aligned, and numpy copies unaligned floats
        element by element, but byte rows as whole blocks)."""
        width = n * np.dtype(dtype).itemsize
        view: npt.NDArray[np.uint8] = np.ndarray(
            shape=(self.count, width),
            dtype=np.uint8,
            buffer=self.buffer,
            offset=self.offset + at,
            strides=(self.stride, 1),
        )
        return view


def _runs(data: bytes, payloads: I64, length: int) -> list[_Rows]:
    """``payloads`` (offsets into ``data``, ascending) as stretches of equal spacing."""
    count = payloads.size
    gaps = np.diff(payloads)
    # Gap indices where the spacing changes: a run of rows ends at the row before such a gap.
    changes = (np.flatnonzero(gaps[1:] != gaps[:-1]) + 1).tolist()
    if len(changes) > _MAX_RUNS_PER_CHUNK:
        view = memoryview(data)
        packed = b"".join([view[o : o + length] for o in payloads.tolist()])
        return [_Rows(packed, 0, length, count)]
    out: list[_Rows] = []
    first = 0
    while first < count:
        if first == count - 1:
            out.append(_Rows(data, int(payloads[first]), length, 1))
            break
        k = bisect.bisect_right(changes, first)
        last = changes[k] if k < len(changes) else count - 1
        out.append(_Rows(data, int(payloads[first]), int(gaps[first]), last - first + 1))
        first = last + 1
    return out


def decode_physics_states(pieces: Sequence[tuple[bytes, I64]]) -> PhysicsStateArrays | None:
    """The states whose message records start at the given offsets of each decompressed
    chunk (``(data, record_offsets)`` in time order), or ``None`` if they are not all of one
    fixed little-endian layout."""
    rows: list[_Rows] = []
    length = -1
    for data, records in pieces:
        if records.size == 0:
            continue
        chunk_bytes = np.frombuffer(data, dtype=np.uint8)
        lengths = gather(chunk_bytes, records + 1, "<u8")
        size = int(lengths[0]) - 22
        if np.any(lengths != lengths[0]) or (length >= 0 and size != length):
            return None
        length = size
        rows.extend(_runs(data, records + MESSAGE_HEADER_SIZE, length))
    if not rows:
        return empty_physics_states()
    if length < 44:
        return None
    head = rows[0]

    def at_first(at: int) -> int:
        return int(head.field(at, "<u4", 1).view("<u4")[0, 0])

    nstate = at_first(24)
    nq_at = 28 + 8 * nstate
    nq = at_first(nq_at) if nq_at + 4 <= length else -1
    nv_at = 36 + 8 * (nstate + max(nq, 0))
    nv = at_first(nv_at) if nq >= 0 and nv_at + 4 <= length else -1
    if nq < 0 or nv < 0 or 44 + 8 * (nstate + nq + nv) != length:
        return None

    def column(at: int, dtype: str, n: int) -> npt.NDArray[Any]:
        packed = np.concatenate([r.field(at, dtype, n) for r in rows])
        values: npt.NDArray[Any] = packed.view(dtype)
        return values

    checks = (
        (column(0, "<u2", 1), _CDR_LE),
        (column(24, "<u4", 1), nstate),
        (column(nq_at, "<u4", 1), nq),
        (column(nv_at, "<u4", 1), nv),
    )
    if any(np.any(values != expected) for values, expected in checks):
        return None
    spec = column(20, "<u4", 1)[:, 0]
    if np.any(spec != spec[0]):
        return None
    return PhysicsStateArrays(
        column(4, "<u8", 1)[:, 0].astype(np.int64),
        column(12, "<i8", 1)[:, 0].astype(np.int64),
        int(spec[0]),
        column(28, "<f8", nstate).astype(np.float64, copy=False),
        column(36 + 8 * nstate, "<f8", nq).astype(np.float64, copy=False),
        column(44 + 8 * (nstate + nq), "<f8", nv).astype(np.float64, copy=False),
    )
