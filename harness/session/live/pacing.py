"""The ``realtime`` clock's pacing, sans I/O: given the wall time now (:func:`time.monotonic`)
and the step reached, when the next step is due and how long a boundary may apply frames.

An *anchor* ``(wall time, step)`` ties simulation time to wall time: step ``k`` is due at
``wall0 + (k - k0) * period`` (``period``: one step's wall-clock seconds, ``dt / rate``). No
anchor (a new clock, a reset, a pause) anchors at the current step. A clock further behind
than :data:`BEHIND_S` re-anchors instead of bursting to catch up.
"""

from __future__ import annotations

__all__ = ["BEHIND_S", "Anchor", "frames_until", "pace", "waiting_until"]

BEHIND_S = 0.25
"""Realtime: further behind than this (seconds), re-anchor instead of bursting."""

Anchor = tuple[float, int]
"""``(wall time, step)``: the step that was (or is) due at that :func:`time.monotonic` time."""


def pace(
    anchor: Anchor | None, now: float, step: int, dt_ns: int, rate: float
) -> tuple[float, Anchor]:
    """How long to wait (seconds, >= 0) before the step after ``step`` (timestep ``dt_ns``,
    ``rate`` x wall time), and the anchor from now on (set when there was none, moved to now
    when the clock is more than :data:`BEHIND_S` behind)."""
    if anchor is None:
        anchor = (now, step)
    wall0, k0 = anchor
    delay = wall0 + (step - k0) * dt_ns / 1e9 / rate - now
    if delay > 0:
        return delay, anchor
    if delay < -BEHIND_S:
        anchor = (now, step)
    return 0.0, anchor


def frames_until(anchor: Anchor | None, now: float, step: int, dt_ns: int, rate: float) -> float:
    """How long a boundary may apply frames (a :func:`time.monotonic` time): until the next
    step is due, less a quarter step for the step itself, and at least one step period when
    the clock is behind (frames and clock then share the time about evenly): a flood of frames
    makes frames wait (for the next boundaries, in arrival order; each recorded at the step it
    took effect) rather than stopping the clock."""
    period = dt_ns / 1e9 / rate
    due = now + period
    if anchor is not None:
        wall0, k0 = anchor
        due = wall0 + (step + 1 - k0) * period
    return now + max(period, due - now - period / 4)


def waiting_until(anchor: Anchor | None, step: int, dt_ns: int, rate: float) -> float | None:
    """While the clock waits for the step after ``step``: until when input read now may be
    applied at once (a :func:`time.monotonic` time: the next step's due time less a quarter
    step for the step itself), None without an anchor."""
    if anchor is None:
        return None
    period = dt_ns / 1e9 / rate
    wall0, k0 = anchor
    return wall0 + (step + 1 - k0) * period - period / 4
