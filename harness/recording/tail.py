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

One writer per path: the file is opened without truncating, locked, then truncated, so a
second writer (another session, in this process or another) fails before touching a byte,
naming the holder's pid (:class:`~harness.recording.errors.RecordingBusyError`). The lock is
an open-file-description lock (Linux ``F_OFD_SETLK``): unlike classic POSIX locks it
conflicts between two opens in one process too, is not dropped when the process closes
another descriptor of the file (a snapshot reading it), and goes with the descriptor when the
holder is killed. Its holder's pid, which such locks do not report, is a second lock on the
byte ``PID_BASE + pid`` far beyond any data: a refused writer asks the kernel which byte of
that range is locked.
"""

from __future__ import annotations

import errno
import fcntl
import os
import stat
import struct

from harness.recording.errors import RecordingBusyError

__all__ = ["PID_BASE", "PID_SPAN", "TailFile", "lock_for_writing"]

PID_BASE = 1 << 62
"""Offset of the pid lock range (beyond any file size: locks there never cover data)."""
PID_SPAN = 1 << 22
"""Pids below this (Linux's ``PID_MAX_LIMIT``) are told through the lock range."""

_FLOCK = struct.Struct("hhqqi4x")  # Linux struct flock: type, whence, start, len, pid
_OFD_SETLK: int | None = getattr(fcntl, "F_OFD_SETLK", None)
_OFD_GETLK: int | None = getattr(fcntl, "F_OFD_GETLK", None)
_ATTEMPTS = 100  # the holder may be between its two locks, or just gone: look again


def lock_for_writing(fd: int, path: str | os.PathLike[str]) -> None:
    """Take the one-writer lock of the file open as ``fd`` (``path`` for the message).

    Raises :class:`~harness.recording.errors.RecordingBusyError` when another open of the
    file holds it (in this process or another); leaves the file untouched either way.
    """
    if _OFD_SETLK is None or _OFD_GETLK is None:  # not Linux: whole-file flock, no pid
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise _busy(path, None) from None
        return
    holder: int | None = None
    for _ in range(_ATTEMPTS):
        try:
            fcntl.fcntl(fd, _OFD_SETLK, _FLOCK.pack(fcntl.F_WRLCK, os.SEEK_SET, 0, 1, 0))
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
        else:
            pid = os.getpid()
            if pid < PID_SPAN:
                fcntl.fcntl(
                    fd, _OFD_SETLK, _FLOCK.pack(fcntl.F_WRLCK, os.SEEK_SET, PID_BASE + pid, 1, 0)
                )
            return
        probe = _FLOCK.pack(fcntl.F_WRLCK, os.SEEK_SET, PID_BASE, PID_SPAN, 0)
        kind, _, start, _, _ = _FLOCK.unpack(fcntl.fcntl(fd, _OFD_GETLK, probe))
        if kind != fcntl.F_UNLCK:
            holder = start - PID_BASE
            break
        os.sched_yield()
    raise _busy(path, holder)


def _busy(path: str | os.PathLike[str], pid: int | None) -> RecordingBusyError:
    if pid is None:
        who = "pid unknown"
    elif pid == os.getpid():
        who = f"pid {pid}, this process"
    else:
        who = f"pid {pid}"
    return RecordingBusyError(
        f"{os.fspath(path)}: another session is recording to this file ({who}): refused "
        "before writing to it; record to another path",
        os.fspath(path),
        pid,
    )


class TailFile:
    """A write-only binary file for :class:`mcap.writer.Writer`: committed writes land in
    order (``tell`` counts only them); :meth:`write_tail` puts provisional bytes after them,
    which the next committed write replaces. Writes go straight to the file descriptor
    (``os.pwrite``, no user-space buffer), so they survive the process being killed.

    Opening takes the file's one-writer lock before truncating it (see the module docstring):
    :class:`~harness.recording.errors.RecordingBusyError` when another writer holds it."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            lock_for_writing(fd, path)
            if stat.S_ISREG(os.fstat(fd).st_mode):  # a device (/dev/full) cannot be cut
                os.ftruncate(fd, 0)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        self._end = 0  # committed bytes
        self._size = 0  # committed bytes plus any provisional tail
        self.closed = False

    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Append committed bytes (over any provisional tail)."""
        view = memoryview(data)
        if not view.nbytes:
            return 0
        self._pwrite_or_note(view, self._end)
        self._end += view.nbytes
        if self._size > self._end:
            # What the provisional tail had beyond the committed bytes goes: the committed
            # chunk written over it holds all of its messages.
            os.ftruncate(self._fd, self._end)
        self._size = self._end
        return view.nbytes

    def write_tail(self, data: bytes) -> None:
        """Write provisional bytes after the committed ones (replacing the last tail)."""
        self._pwrite_or_note(memoryview(data), self._end)
        if self._size > self._end + len(data):
            os.ftruncate(self._fd, self._end + len(data))
        self._size = self._end + len(data)

    def _pwrite_or_note(self, view: memoryview, offset: int) -> None:
        try:
            self._pwrite(view, offset)
        except OSError:
            # A full disk can take part of the bytes before refusing the rest: the next
            # committed write, or closing, cuts whatever reached the file beyond them.
            self._size = max(self._size, offset + view.nbytes)
            raise

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
