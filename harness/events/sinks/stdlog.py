"""A sink to stdlib :mod:`logging`: message as text, the event as structured ``extra``."""

from __future__ import annotations

import logging

from harness.events.events import Event
from harness.events.sinks.base import SinkReport

__all__ = ["LoggingSink"]


class LoggingSink:
    """Logs each event to ``logger`` at the event's level (the numbers match stdlib levels).

    The record gets one attribute, ``record.harness``: ``Event.to_dict()`` (a single
    attribute, so event fields such as ``name`` never clash with ``LogRecord``'s own).
    """

    name = "logging"

    def __init__(self, logger: str | logging.Logger = "harness.events") -> None:
        self.logger = logging.getLogger(logger) if isinstance(logger, str) else logger
        self._delivered = 0
        self._report: SinkReport | None = None

    def emit(self, event: Event) -> None:
        """Log ``event`` (skipped, and not counted, below the logger's effective level)."""
        level = int(event.level)
        if not self.logger.isEnabledFor(level):
            return
        self.logger.log(level, "%s", event.message(), extra={"harness": event.to_dict()})
        self._delivered += 1

    def close(self) -> SinkReport:
        """Report the records logged."""
        if self._report is None:
            self._report = SinkReport(self.name, self._delivered, 0, self.logger.name)
        return self._report
