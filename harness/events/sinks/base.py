"""The sink protocol and its end-of-run report."""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

from harness.events.events import Event

__all__ = ["Sink", "SinkReport"]


class SinkReport(NamedTuple):
    """What a sink did over a run: events ``delivered`` (written, sent and acknowledged) and
    ``dropped`` (accepted but lost: queue full, server unreachable, deadline passed). Events a
    sink does not carry by design (joint samples in the recording) count as neither."""

    name: str
    delivered: int
    dropped: int
    note: str = ""


@runtime_checkable
class Sink(Protocol):
    """Receives events. ``emit`` must be cheap and never block the simulation; ``close``
    flushes (within the sink's own deadline) and reports. Sinks are found by name through the
    ``harness.sinks`` entry-point group (:func:`harness.events.sinks.create_sink`)."""

    @property
    def name(self) -> str: ...

    def emit(self, event: Event) -> None:
        """Accept one event."""
        ...

    def close(self) -> SinkReport:
        """Flush, release resources and report; later calls return the same report."""
        ...
