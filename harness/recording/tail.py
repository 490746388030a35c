"""Crash safety without wall-clock chunk boundaries: a provisional tail.

Chunk boundaries decide a recording's bytes (chunk records, message indexes, the summary), so
they are decided by size alone (the mcap writer's ``chunk_size``), never by the wall clock:
two identical runs give identical files. Crash safety still needs the open chunk on disk
within about a second of wall time; so the recorder's flush thread writes the open chunk as a
complete, CRC-checked chunk record plus its message indexes *after* the committed bytes
(:func:`provisional_chunk`), without telling the writer. The next committed write (the chunk
closing for real, which holds every message of the provisional one and more, or the summary)
is written over it, and whatever the provisional tail had beyond the committed bytes is cut
off: the finished file holds only what the writer wrote.

A process killed at any moment leaves committed chunks, then the last provisional tail (or
the committed chunk that superseded it): every message up to the last flush reads back.
"""

from __future__ import annotations

import os
import zlib
from typing import Any

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Chunk
from mcap.writer import CompressionType, Writer

__all__ = ["TailFile", "provisional_chunk"]


class TailFile:
    """A write-only binary file for :class:`mcap.writer.Writer`: committed writes land in
    order (``tell`` counts only them); :meth:`write_tail` puts provisional bytes after them,
    which the next committed write replaces. Writes go straight to the file descriptor
    (``os.pwrite``, no user-space buffer), so they survive the process being killed."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self._end = 0  # committed bytes
        self._size = 0  # committed bytes plus any provisional tail
        self.closed = False

    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Append committed bytes (over any provisional tail)."""
        view = memoryview(data)
        if not view.nbytes:
            return 0
        self._pwrite(view, self._end)
        self._end += view.nbytes
        if self._size > self._end:
            # What the provisional tail had beyond the committed bytes goes: the committed
            # chunk written over it holds all of its messages.
            os.ftruncate(self._fd, self._end)
        self._size = self._end
        return view.nbytes

    def write_tail(self, data: bytes) -> None:
        """Write provisional bytes after the committed ones (replacing the last tail)."""
        self._pwrite(memoryview(data), self._end)
        if self._size > self._end + len(data):
            os.ftruncate(self._fd, self._end + len(data))
        self._size = self._end + len(data)

    def _pwrite(self, view: memoryview, offset: int) -> None:
        while view.nbytes:
            written = os.pwrite(self._fd, view, offset)
            view, offset = view[written:], offset + written

    def tell(self) -> int:
        """Committed bytes (the offsets the writer indexes)."""
        return self._end

    @property
    def size(self) -> int:
        """Bytes in the file: committed plus the provisional tail."""
        return self._size

    def flush(self) -> None:
        """Nothing to do: every write reached the file system already."""

    def close(self) -> None:
        """Cut any provisional tail and close the file (idempotent)."""
        if self.closed:
            return
        self.closed = True
        try:
            if self._size > self._end:
                os.ftruncate(self._fd, self._end)
        finally:
            os.close(self._fd)


def provisional_chunk(writer: Writer, compression: CompressionType) -> bytes | None:
    """The chunk ``writer`` has open, as the chunk record and message index records it would
    write if the chunk closed now (``None``: no message in it). Reads the writer's chunk
    builder without changing it (mcap 1.6's private attribute: pinned in constraints.txt)."""
    builder: Any = getattr(writer, "_Writer__chunk_builder", None)
    if builder is None or builder.num_messages == 0:
        return None
    data = builder.record_writer._buffer.getvalue()
    if compression == CompressionType.ZSTD:
        name, packed = "zstd", zstandard.compress(data)
    elif compression == CompressionType.LZ4:
        import lz4.frame  # type: ignore[import-untyped]

        name, packed = "lz4", lz4.frame.compress(data)
    else:
        name, packed = "", data
    out = RecordBuilder()
    Chunk(
        compression=name,
        data=packed,
        message_start_time=builder.message_start_time,
        message_end_time=builder.message_end_time,
        uncompressed_crc=zlib.crc32(data),
        uncompressed_size=len(data),
    ).write(out)
    for index in builder.message_indices.values():
        index.write(out)
    tail: bytes = out.end()  # type: ignore[no-untyped-call]
    return tail
