"""A sink writing one JSON object per event per line (``Event.to_dict``)."""

from __future__ import annotations

import json
from pathlib import Path

from harness.events.errors import SinkError
from harness.events.events import Event
from harness.events.sinks.base import SinkReport

__all__ = ["JsonLinesSink"]


class JsonLinesSink:
    """Appends (``append=True``) or writes ``path``: one ``Event.to_dict()`` per line."""

    name = "jsonl"

    def __init__(self, path: str | Path, *, append: bool = False) -> None:
        self.path = Path(path)
        try:
            self._file = self.path.open("a" if append else "w", encoding="utf-8")
        except OSError as exc:
            raise SinkError(f"jsonl sink: cannot open {self.path}: {exc.strerror}") from None
        self._delivered = 0
        self._report: SinkReport | None = None

    def emit(self, event: Event) -> None:
        """Write one line (buffered; flushed at close)."""
        self._file.write(json.dumps(event.to_dict(), separators=(",", ":")) + "\n")
        self._delivered += 1

    def close(self) -> SinkReport:
        """Flush and close the file."""
        if self._report is None:
            self._file.close()
            self._report = SinkReport(self.name, self._delivered, 0, str(self.path))
        return self._report
