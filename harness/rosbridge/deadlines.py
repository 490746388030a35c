"""Deadlines of pending service calls and action goals: bounded, cancellable, cheap.

A client chooses a call's ``timeout``; it is a number from the network, so it is checked
(:func:`bounded_timeout`: NaN and negative values refused, ``Infinity`` and anything above
:data:`MAX_TIMEOUT_S` clamped to the cap) before it sets a timer. Pending deadlines live in
:class:`Deadlines`, a heap keyed by ``(deadline, seq)``: inserting 100,000 equal deadlines
costs what 100,000 different ones do (asyncio timer handles hash by their expiry time, so a
set of them degrades to quadratic time when the expiries are equal). A cancelled deadline is
dropped lazily and the heap is rebuilt once most of it is dead, so memory stays proportional
to the deadlines still pending. Sans-I/O: the owner asks :meth:`Deadlines.pop_due` at the
time :meth:`Deadlines.next_deadline` names.
"""

from __future__ import annotations

import heapq
import itertools
import math

from harness.rosbridge.errors import FrameError

__all__ = ["MAX_TIMEOUT_S", "Deadlines", "bounded_timeout"]

MAX_TIMEOUT_S = 3600.0
"""The longest timeout a client can ask for (seconds of wall time); longer ones, and
``Infinity``, are clamped to it."""


def bounded_timeout(value: float | None, default: float, op: str) -> float:
    """The timeout to enforce for a client's ``timeout`` field of ``op`` (``None``: the
    default): finite and at most :data:`MAX_TIMEOUT_S`; NaN or a negative value raises
    :class:`FrameError`."""
    if value is None:
        value = default
    value = float(value)
    if math.isnan(value) or value < 0:
        raise FrameError(f"{op}: timeout must be a number of seconds >= 0, not {value!r}")
    return min(value, MAX_TIMEOUT_S)


class Deadlines:
    """Pending deadlines by key (one per key): add, cancel, pop those due."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, int]] = []
        self._live: dict[int, int] = {}  # key -> seq of its live heap entry
        self._seq = itertools.count()

    def __len__(self) -> int:
        return len(self._live)

    def __contains__(self, key: object) -> bool:
        return key in self._live

    def add(self, key: int, deadline: float) -> None:
        """Set ``key``'s deadline (replacing an earlier one for the same key)."""
        seq = next(self._seq)
        self._live[key] = seq
        heapq.heappush(self._heap, (deadline, seq, key))
        self._compact()

    def cancel(self, key: int) -> None:
        """Forget ``key``'s deadline (no-op when it has none)."""
        if self._live.pop(key, None) is not None:
            self._compact()

    def next_deadline(self) -> float | None:
        """The earliest live deadline, or ``None`` when nothing is pending."""
        self._skip_dead()
        return self._heap[0][0] if self._heap else None

    def pop_due(self, now: float) -> list[int]:
        """Remove and return the keys whose deadline is ``<= now``, earliest first."""
        due: list[int] = []
        while True:
            self._skip_dead()
            if not self._heap or self._heap[0][0] > now:
                return due
            _, _, key = heapq.heappop(self._heap)
            del self._live[key]
            due.append(key)

    def _skip_dead(self) -> None:
        heap = self._heap
        while heap and self._live.get(heap[0][2]) != heap[0][1]:
            heapq.heappop(heap)

    def _compact(self) -> None:
        if len(self._heap) > 64 and len(self._heap) > 2 * len(self._live):
            self._heap = [e for e in self._heap if self._live.get(e[2]) == e[1]]
            heapq.heapify(self._heap)
