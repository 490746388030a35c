"""The bounds on what one rosbridge client can make the bridge hold or do, in one place.

Memory: frames of :data:`MAX_FRAME_BYTES`, :data:`SEND_QUEUE_BYTES` unsent per client and
:data:`MAX_QUEUED_BYTES` for every client together (:class:`~harness.rosbridge.BridgeServer`),
:data:`MAX_FRAGMENT_BYTES` of incoming fragments per client, pending service calls and action
goals per client (:data:`MAX_PENDING_CALLS_PER_CLIENT`, :data:`MAX_PENDING_GOALS_PER_CLIENT`) and
in total (:data:`MAX_PENDING_CALLS`, :data:`MAX_PENDING_GOALS`); their timeouts are bounded in
:mod:`harness.rosbridge.deadlines`.

Work: a ``fragment_size`` below :data:`MIN_FRAGMENT_SIZE` is raised to it (one frame per
character made a client's messages cost thousands of frames each), and a session's bridge
charges every frame it sends a client for its subscriptions to that client's send budget
(:class:`SendBudget`, on the bridge's clock: simulation time in a session): a client over it
has its subscription messages dropped, as a slow subscriber's are, instead of the simulation
waiting for them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

__all__ = [
    "BUDGET_BURST_S",
    "MAX_FRAGMENT_BYTES",
    "MAX_FRAME_BYTES",
    "MAX_PENDING_CALLS",
    "MAX_PENDING_CALLS_PER_CLIENT",
    "MAX_PENDING_GOALS",
    "MAX_PENDING_GOALS_PER_CLIENT",
    "MAX_QUEUED_BYTES",
    "MIN_FRAGMENT_SIZE",
    "SEND_BYTES_PER_S",
    "SEND_FRAMES_PER_S",
    "SEND_QUEUE_BYTES",
    "SendBudget",
    "over_pending_limit",
]

MAX_FRAME_BYTES: Final = 16 * 2**20
"""The largest frame a client may send (larger ones close the connection, status 1009)."""
SEND_QUEUE_BYTES: Final = 256 * 2**20
"""Unsent bytes one client may have waiting before it is closed (status 1008)."""
MAX_QUEUED_BYTES: Final = 512 * 2**20
"""Unsent bytes of every client together before the slowest are closed (status 1008)."""
MAX_FRAGMENT_BYTES: Final = 16 * 2**20
"""Bytes of incomplete incoming fragmented messages one client may have."""

MIN_FRAGMENT_SIZE: Final = 1024
"""The smallest ``fragment_size`` (characters per ``fragment`` frame) a client gets; a smaller
one is raised to it, with a ``warning`` status naming the asked and the applied value."""

MAX_PENDING_CALLS_PER_CLIENT: Final = 1000
"""Service calls one client may have waiting for an answer; one more is refused (a failed
``service_response`` naming the limit). The reference server has one: a call blocks the
client's later frames."""
MAX_PENDING_CALLS: Final = 10_000
"""Service calls every client together may have waiting for an answer."""
MAX_PENDING_GOALS_PER_CLIENT: Final = 1000
"""Action goals one client may have active; one more is refused (a failed ``action_result``
naming the limit)."""
MAX_PENDING_GOALS: Final = 10_000
"""Action goals every client together may have active."""

SEND_FRAMES_PER_S: Final = 5000
"""A session client's send budget in subscription frames per second of the bridge's clock
(each frame costs 1/5,000 s of budget, plus its bytes' share of :data:`SEND_BYTES_PER_S`). A
frame costs the session thread some 15 to 40 us (built, recorded, queued, written): a client
at this rate alone takes about a tenth of a core. Robot software subscribing to every topic of
a robot needs well under it (the demo arm's /joint_states, /tf and /clock: 300 frames/s)."""
SEND_BYTES_PER_S: Final = 64 * 2**20
"""A session client's send budget in bytes per second of the bridge's clock: room for a
320x240 RGB-D camera at 30 Hz in JSON (about 21 MB/s) and more."""
BUDGET_BURST_S: Final = 0.1
"""How far (seconds of budget) a client may send ahead of its rate before it is throttled."""


@dataclass(frozen=True)
class SendBudget:
    """What a client may be sent per second of the bridge's clock: ``frames_per_s`` frames and
    ``bytes_per_s`` bytes, shared (a frame costs ``1/frames_per_s`` s plus
    ``len / bytes_per_s`` s of budget), ``burst_s`` s of budget ahead of the rate at most.
    Counted in integer nanoseconds of the bridge's clock, so the same inputs throttle the same
    messages: a replay sends (and records) what the live run did."""

    frames_per_s: int = SEND_FRAMES_PER_S
    bytes_per_s: int = SEND_BYTES_PER_S
    burst_s: float = BUDGET_BURST_S
    frame_ns: int = field(init=False, repr=False, compare=False)
    """Budget one frame costs, besides its bytes (ns)."""
    burst_ns: int = field(init=False, repr=False, compare=False)
    """How far ahead of the clock a client's spending may run (ns)."""

    def __post_init__(self) -> None:
        if self.frames_per_s <= 0 or self.bytes_per_s <= 0 or not self.burst_s >= 0:
            raise ValueError(
                f"SendBudget: frames_per_s and bytes_per_s must be > 0 and burst_s >= 0, "
                f"got {self.frames_per_s}, {self.bytes_per_s}, {self.burst_s}"
            )
        object.__setattr__(self, "frame_ns", 1_000_000_000 // self.frames_per_s)
        object.__setattr__(self, "burst_ns", int(self.burst_s * 1e9))

    def cost_ns(self, frames: int, nbytes: int) -> int:
        """Budget ``frames`` frames of ``nbytes`` bytes together cost (ns)."""
        return frames * self.frame_ns + nbytes * 1_000_000_000 // self.bytes_per_s

    def describe(self) -> str:
        """The budget as a client's status text names it."""
        return (
            f"{self.frames_per_s} frames or {self.bytes_per_s // 2**20} MiB per second of "
            "simulation time"
        )


def over_pending_limit(
    what: str,
    state: str,
    mine: int,
    per_client: tuple[str, int],
    total: int,
    overall: tuple[str, int],
) -> str | None:
    """Why a client with ``mine`` ``what`` in ``state`` ("calls", "are pending"), of ``total``
    for every client, may not start one more: the limit (name, value) it reached, or None."""
    name, limit = per_client
    if mine >= limit:
        return f"{mine} {what} of this client {state}, the limit per client ({name} {limit})"
    name, limit = overall
    if total >= limit:
        return f"{total} {what} {state}, the limit for all clients together ({name} {limit})"
    return None
