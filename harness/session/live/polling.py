"""Busy-polling while time stands still: the session loop's selector (:class:`PollingSelector`).

A lockstep client in another process sends its next request a few hundred microseconds after
our answer. Blocking in ``epoll_wait`` for it idles the CPU, and on a virtual machine the
wake-up costs a host round trip and cold caches: measured here, the session's work per request
ran about twice as slow live as in a hot loop, and a bare ``websockets`` server beat us by more
than our own work explains. Polling the sockets for a short, adaptive window before blocking
keeps the thread warm (the guest kernel's ``haltpoll`` governor does the same for idle CPUs,
and is off on these machines).

The window adapts as ``haltpoll``'s does: a wait that ended soon after the window had run out
doubles it (from :data:`GROW_START_NS` up to :data:`MAX_NS`), a wait longer than
:data:`MAX_NS` halves it, so a client that thinks for longer than the window costs one short
spin now and then, not a core. Polling runs only when the owner says time stands still
(:attr:`PollingSelector.should_poll`) and every connected peer lives in another process: a
polling thread keeps the GIL from the other threads of our process (CPython gives it back to
the thread that released it; measured: an in-process test client ran 30% slower), so a peer in
this process turns polling off, and so does a call handed to the loop by another thread of ours
(:attr:`PollingSelector.called`: a test stepping the session from Python runs code between its
calls). Nor does it poll while more tasks are runnable than there are CPUs (``/proc/loadavg``):
on a busy machine (``pytest -n 2`` on two cores) the window would be taken from another task,
the client among them; measured, the whole suite ran 14% slower polling regardless. Polling
changes when the loop wakes, never what a step does: recordings are the same bytes.
"""

from __future__ import annotations

import os
import selectors
import socket
import time
from collections.abc import Callable
from typing import Any

__all__ = ["GROW_START_NS", "MAX_NS", "PollingSelector", "next_window", "peer_in_process"]

MAX_NS = 300_000
"""The longest polling window (a lockstep client's think time between answer and request
is ~100-250 us here)."""
GROW_START_NS = 40_000
"""The window a wait that ended soon after blocking grows an empty window to."""
_KNOWN_MAX = 1024


def _hex_address(host: str, port: int) -> str | None:
    """``host:port`` as ``/proc/net/tcp*`` writes a local address (None: not an IP)."""
    try:
        if ":" in host:
            raw = socket.inet_pton(socket.AF_INET6, host)
            # four 32-bit words, each in host (little-endian) order
            words = [raw[i : i + 4][::-1].hex().upper() for i in range(0, 16, 4)]
            return f"{''.join(words)}:{port:04X}"
        raw = socket.inet_pton(socket.AF_INET, host)
        return f"{raw[::-1].hex().upper()}:{port:04X}"
    except OSError:
        return None


def peer_in_process(sock: socket.socket) -> bool:
    """Whether the other end of connected TCP socket ``sock`` is a socket of this process.
    True where that cannot be read (no Linux ``/proc``, no peer, not TCP): callers treat
    unknown as local, the safe side."""
    try:
        host, port = sock.getpeername()[:2]
        want = _hex_address(host, port)
        if want is None:
            return True
        mine = set()
        for fd in os.listdir("/proc/self/fd"):
            try:
                link = os.readlink(f"/proc/self/fd/{fd}")
            except OSError:
                continue
            if link.startswith("socket:["):
                mine.add(link[8:-1])
        for table in ("/proc/net/tcp", "/proc/net/tcp6"):
            try:
                with open(table) as f:
                    next(f)
                    for line in f:
                        fields = line.split()
                        if fields[1] == want:
                            return fields[9] in mine
            except OSError:
                continue
    except (OSError, ValueError, IndexError):
        return True
    return False


def _tcp_peer(fd: int) -> tuple[socket.socket, Any] | None:
    """A duplicate of TCP socket ``fd`` (the caller closes it) and its peer; None when ``fd``
    is no connected TCP socket (the listening socket, the loop's self-pipe, a file)."""
    try:
        sock = socket.socket(fileno=os.dup(fd))
    except OSError:
        return None
    try:
        if sock.family in (socket.AF_INET, socket.AF_INET6) and sock.type == socket.SOCK_STREAM:
            return sock, sock.getpeername()
    except OSError:
        pass
    sock.close()
    return None


class PollingSelector(selectors.DefaultSelector):
    """The platform's selector, polling before it blocks while :attr:`should_poll` says so
    and every TCP peer registered for reading is in another process (module docstring).
    ``max_ns``: the longest window (0: never poll)."""

    def __init__(self, max_ns: int = MAX_NS) -> None:
        super().__init__()
        self.should_poll: Callable[[], bool] = lambda: False
        self.max_ns = max_ns
        self.window_ns = 0
        self.called = False
        """Set by the owner when another thread of ours hands the loop a call: the next wait
        blocks (that thread runs Python between its calls and would wait for our GIL)."""
        self.polled = 0
        """Waits that ended while polling (what the window won)."""
        self._peers: dict[int, bool] = {}
        """Registered fd -> in this process, for TCP connections."""
        self._local = 0
        self._known: dict[tuple[int, Any], bool] = {}
        """(fd, peer) -> in this process: looked up once per connection."""
        self.cpu_free: Callable[[], bool] = self.runnable_fit
        """Whether a CPU is free to poll on (:meth:`runnable_fit`; tests replace it)."""
        self._cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
        try:
            self._loadavg: int | None = os.open("/proc/loadavg", os.O_RDONLY)
        except OSError:
            self._loadavg = None

    def close(self) -> None:
        super().close()
        if self._loadavg is not None:
            os.close(self._loadavg)
            self._loadavg = None

    def runnable_fit(self) -> bool:
        """Whether every runnable task has a CPU (``/proc/loadavg``'s running count, this
        thread included): polling on a busy machine would take one from another task."""
        if self._loadavg is None:
            return False
        try:
            running = int(os.pread(self._loadavg, 64, 0).split()[3].split(b"/")[0])
        except (OSError, ValueError, IndexError):
            return False
        return running <= self._cpus

    # ------------------------------------------------------------------------ registration

    def register(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        key = super().register(fileobj, events, data)
        if self.max_ns and events & selectors.EVENT_READ:
            self._track(key.fd)
        return key

    def unregister(self, fileobj: Any) -> selectors.SelectorKey:
        key = super().unregister(fileobj)
        self._untrack(key.fd)
        return key

    def modify(self, fileobj: Any, events: int, data: Any = None) -> selectors.SelectorKey:
        before = self.get_key(fileobj)
        key = super().modify(fileobj, events, data)
        if (before.events ^ events) & selectors.EVENT_READ:
            if events & selectors.EVENT_READ:
                self._track(key.fd)
            else:
                self._untrack(key.fd)
        return key

    def _track(self, fd: int) -> None:
        if fd in self._peers:
            return
        found = _tcp_peer(fd)
        if found is None:
            return
        sock, peer = found
        with sock:
            local = self._known.get((fd, peer))
            if local is None:
                if len(self._known) >= _KNOWN_MAX:  # a long-running server's old peers
                    self._known.clear()
                local = self._known[(fd, peer)] = peer_in_process(sock)
        self._peers[fd] = local
        self._local += local

    def _untrack(self, fd: int) -> None:
        local = self._peers.pop(fd, None)
        if local is not None:
            self._local -= local

    @property
    def polling(self) -> bool:
        """Whether a wait now would poll before blocking (peers, none local, owner agrees)."""
        return bool(self.max_ns and self._peers and not self._local and self.should_poll())

    # ------------------------------------------------------------------------ waiting

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        select = super().select
        if timeout is not None and timeout <= 0:
            return select(timeout)
        called, self.called = self.called, False  # taken by a wait, not by a look
        if called or not self.polling or not self.cpu_free():
            return select(timeout)
        now = time.perf_counter_ns
        start = now()
        window = self.window_ns
        limit = window if timeout is None else min(window, int(timeout * 1e9))
        while limit:
            ready = select(0)
            if ready:
                self.polled += 1
                return ready
            if now() - start >= limit:
                break
        rest = None if timeout is None else max(0.0, timeout - (now() - start) / 1e9)
        ready = select(rest)
        self.window_ns = next_window(self.window_ns, now() - start, self.max_ns)
        return ready


def next_window(window_ns: int, waited_ns: int, max_ns: int) -> int:
    """The polling window after a wait of ``waited_ns`` that outlasted a window of
    ``window_ns``: doubled (from :data:`GROW_START_NS`, up to ``max_ns``) when the wait ended
    within ``max_ns``, else halved (to 0 below :data:`GROW_START_NS`)."""
    if waited_ns <= max_ns:
        return min(max_ns, max(GROW_START_NS, window_ns * 2))
    window_ns //= 2
    return window_ns if window_ns >= GROW_START_NS else 0
