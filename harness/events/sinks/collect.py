"""A sink that keeps events in memory (tests, and the pytest plugin's report section)."""

from __future__ import annotations

from collections import Counter

from harness.events.events import Event, Level
from harness.events.sinks.base import SinkReport

__all__ = ["CollectingSink"]


class CollectingSink:
    """Keeps every event, in order; :meth:`report_lines` summarises them for a test report."""

    name = "collect"

    def __init__(self, *, min_level: Level = Level.DEBUG) -> None:
        self.min_level = Level(min_level)
        self.events: list[Event] = []
        self._report: SinkReport | None = None

    def emit(self, event: Event) -> None:
        """Keep ``event`` when its level is at least ``min_level``."""
        if event.level >= self.min_level:
            self.events.append(event)

    def of_kind(self, *types: type[Event]) -> list[Event]:
        """The kept events that are instances of any of ``types``."""
        return [e for e in self.events if isinstance(e, types)]

    def report_lines(self, *, max_lines: int = 50) -> list[str]:
        """A count per event kind, then the messages (samples left out), at most ``max_lines``."""
        counts = Counter(e.kind for e in self.events)
        lines = [", ".join(f"{kind}: {n}" for kind, n in sorted(counts.items()))]
        shown = [e for e in self.events if e.kind != "joint_sample"]
        for event in shown[:max_lines]:
            lines.append(f"[{event.level.name} step {event.step}] {event.message()}")
        if len(shown) > max_lines:
            lines.append(f"... {len(shown) - max_lines} more")
        return lines

    def close(self) -> SinkReport:
        """Report every kept event as delivered."""
        if self._report is None:
            self._report = SinkReport(self.name, len(self.events), 0)
        return self._report
