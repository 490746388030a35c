"""Crash safety without wall-clock chunk boundaries: a provisional tail.

Chunk boundaries decide a recording's bytes (chunk records, message indexes, the summary), so
they are decided by size alone (the writer's ``chunk_size``), never by the wall clock:
two identical runs give identical files. Crash safety still needs the open chunk on disk
within about a second of wall time; so the recorder's flush thread writes the open chunk as a
complete, CRC-checked chunk record plus its message indexes *after* the committed bytes
(:meth:`harness.recording.writer.ChunkWriter.provisional`), without closing it. The next
committed write (the chunk closing for real, which holds every message of the provisional one
and more, or the summary) is written over it, and whatever the provisional tail had beyond the
committed bytes is cut off: the finished file holds only what the writer wrote.

A process killed at any moment leaves committed chunks, then the last provisional tail (or
the committed chunk that superseded it): every message up to the last flush reads back.
"""

from __future__ import annotations

import os

__all__ = ["TailFile"]


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
