"""Per-client send budgets (a room of :class:`~harness.rosbridge.Bridge`, mixed into it).

Every frame the bridge sends a client for its subscriptions (what one ``subscribe`` can make
unbounded) costs that client budget (:meth:`harness.rosbridge.limits.SendBudget.cost_ns`: a
share per frame plus a share per byte), counted as a point on the bridge's clock up to which
the client's budget is spent (a generic cell rate algorithm: no timers, one integer per
client). A client whose budget is
spent past the bridge's time has its subscription messages dropped, before they are built,
fragmented, recorded or queued, so the work one client causes per second of simulation time
is bounded whatever it subscribes to and however it asks for it. Answers (service responses,
action results and feedback, statuses) are neither charged nor dropped: they come one for
each frame the client sends, which the session already paces (a lockstep client stepping a
10 kHz simulation one step per call gets 10,000 answers per simulated second, and its
subscriptions still flow). Drops are counted per topic
(:meth:`BudgetOps.throttled`) and reported to the client in ``warning`` statuses (``dropped N
messages on T: ...``, as the server reports drops for a slow reader) at most once per second
of the bridge's clock. Everything is a function of the bridge's inputs and time:
what is dropped is never sent nor recorded, the same in a replay.
"""

from __future__ import annotations

from harness.rosbridge.frames import BridgeHost, Connection
from harness.rosbridge.limits import SendBudget

__all__ = ["REPORT_EVERY_NS", "BudgetOps"]

REPORT_EVERY_NS = 1_000_000_000
"""At most one throttling ``warning`` per client per this much of the bridge's clock."""


class BudgetOps(BridgeHost):
    """Charging frames to their client's :class:`SendBudget` and throttling clients over it
    (``send_budget``: every new connection's; None: no budget)."""

    send_budget: SendBudget | None

    def _over_budget(self, conn: Connection, now_ns: int) -> bool:
        """Whether ``conn``'s budget is spent past ``now_ns`` (then its subscription messages
        are dropped)."""
        spent = conn.spent_until_ns
        if spent is None:
            return False
        if now_ns < conn.budget_now_ns:  # the clock went back (a new epoch): so does the debt
            spent = conn.spent_until_ns = spent - (conn.budget_now_ns - now_ns)
            conn.budget_now_ns = now_ns
        return spent > now_ns

    def _charge(self, conn: Connection, budget: SendBudget, nbytes: int, now_ns: int) -> None:
        """Charge one frame of ``nbytes`` bytes sent at ``now_ns`` to ``conn``."""
        spent = conn.spent_until_ns
        if spent is None:
            spent = now_ns - budget.burst_ns
        else:
            if now_ns < conn.budget_now_ns:
                spent -= conn.budget_now_ns - now_ns
            floor = now_ns - budget.burst_ns
            if spent < floor:
                spent = floor
        conn.budget_now_ns = now_ns
        conn.spent_until_ns = spent + budget.frame_ns + nbytes * 1_000_000_000 // budget.bytes_per_s

    def _throttle(self, conn: Connection, topic: str) -> None:
        """Count a subscription message on ``topic`` not sent to ``conn``; tell the client,
        a ``warning`` per topic, at most once per :data:`REPORT_EVERY_NS`."""
        conn.throttled[topic] = conn.throttled.get(topic, 0) + 1
        conn.unreported[topic] = conn.unreported.get(topic, 0) + 1
        now = self._now_ns
        if conn.report_after_ns is not None and now < conn.report_after_ns:
            return
        conn.report_after_ns = now + REPORT_EVERY_NS
        assert conn.budget is not None
        budget = conn.budget.describe()
        for name, n in sorted(conn.unreported.items()):
            # the text of the server's drops for a slow reader, the reason apart
            self.status(
                conn.id,
                "warning",
                f"dropped {n} messages on {name}: this client is over its send budget of "
                f"{budget} (subscribe with throttle_rate or to fewer topics)",
            )
        conn.unreported.clear()

    def exempt_from_budget(self, connection: int) -> None:
        """Send ``connection`` everything, whatever it costs: for the harness's own links (a
        client-mode session's connection to the external server carries every client's
        traffic), never for a client."""
        conn = self._conns.get(connection)
        if conn is not None:
            conn.budget = None

    def throttled(self, connection: int) -> dict[str, int]:
        """How many subscription messages, by topic, ``connection`` was not sent because it
        was over its send budget (empty for an unknown connection)."""
        conn = self._conns.get(connection)
        return {} if conn is None else dict(conn.throttled)
