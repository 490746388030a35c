"""The logger interface: :class:`StepContext`, the :class:`Logger` protocol, :class:`EventHub`.

A logger observes the simulation after a step and returns typed events; the hub calls each
registered logger when it is due (every step, or at its own period in *simulation* time),
passes the events to every sink, and at the end of the run lets loggers close what is open
(:meth:`Logger.finish`) and collects each sink's :class:`~harness.events.sinks.SinkReport`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple, Protocol, runtime_checkable

import mujoco

from harness.events.events import Event
from harness.events.sinks.base import Sink, SinkReport
from harness.sim import ContactSet

__all__ = ["EventHub", "Logger", "SimulationView", "StepContext", "period_ns_from_hz"]


class SimulationView(Protocol):
    """What :meth:`StepContext.of` reads from a simulation (``harness.sim.Simulation``)."""

    @property
    def step_index(self) -> int: ...
    @property
    def sim_time_ns(self) -> int: ...
    @property
    def model(self) -> mujoco.MjModel: ...
    @property
    def data(self) -> mujoco.MjData: ...
    def contacts(self) -> ContactSet: ...


class StepContext(NamedTuple):
    """The simulation right after step ``step`` (at ``sim_time_ns``), seen for ``robot``.

    ``contacts`` are those of ``data`` (computed once per step and shared by loggers).
    """

    step: int
    sim_time_ns: int
    model: mujoco.MjModel
    data: mujoco.MjData
    contacts: ContactSet
    robot: str

    @classmethod
    def of(cls, sim: SimulationView, robot: str) -> StepContext:
        """The context of ``sim``'s current step."""
        return cls(sim.step_index, sim.sim_time_ns, sim.model, sim.data, sim.contacts(), robot)


@runtime_checkable
class Logger(Protocol):
    """Observes steps and emits events.

    ``period_ns``: how often the hub calls :meth:`observe`, in simulation time (0: every
    step); it is called at the first observed step at or after each multiple of the period.
    """

    @property
    def name(self) -> str: ...

    @property
    def period_ns(self) -> int: ...

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """Events caused by this step."""
        ...

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        """Events that close what is still open (collisions, violations) at the end of a run."""
        ...


def period_ns_from_hz(rate_hz: float | None) -> int:
    """A period in integer nanoseconds from a rate in Hz (None or 0: every step)."""
    if rate_hz is None or rate_hz == 0:
        return 0
    if not rate_hz > 0:
        raise ValueError(f"rate must be > 0 Hz, got {rate_hz}")
    return max(1, round(1e9 / rate_hz))


class _Registered:
    __slots__ = ("logger", "next_due_ns", "period_ns")

    def __init__(self, logger: Logger) -> None:
        self.logger = logger
        self.period_ns = int(logger.period_ns)
        self.next_due_ns = 0


class EventHub:
    """Runs loggers after each step and fans their events out to sinks.

    A sink that raises on ``emit`` does not stop the run: that sink gets no further events,
    every event it missed is added to its ``dropped`` count and its report's ``note`` names the
    error; the other sinks keep receiving.
    """

    def __init__(self, loggers: Iterable[Logger] = (), sinks: Iterable[Sink] = ()) -> None:
        self._loggers = [_Registered(logger) for logger in loggers]
        self._sinks = list(sinks)
        self._errors: dict[int, str] = {}
        self._lost: dict[int, int] = {}
        self._closed = False

    @property
    def loggers(self) -> tuple[Logger, ...]:
        return tuple(r.logger for r in self._loggers)

    def has_loggers(self) -> bool:
        """Whether any logger is registered (without building :attr:`loggers`)."""
        return bool(self._loggers)

    @property
    def sinks(self) -> tuple[Sink, ...]:
        return tuple(self._sinks)

    def add_logger(self, logger: Logger) -> None:
        """Register a logger (called from the next observed step on)."""
        self._loggers.append(_Registered(logger))

    def add_sink(self, sink: Sink) -> None:
        """Register a sink (receives events emitted from now on)."""
        self._sinks.append(sink)

    def observe(self, ctx: StepContext) -> list[Event]:
        """Run every due logger on this step; returns the events (already emitted)."""
        out: list[Event] = []
        t = ctx.sim_time_ns
        for reg in self._loggers:
            if reg.period_ns:
                if t < reg.next_due_ns:
                    continue
                reg.next_due_ns = (t // reg.period_ns + 1) * reg.period_ns
            events = reg.logger.observe(ctx)
            if events:
                out.extend(events)
        if out:
            self.emit(out)
        return out

    def finish(self, ctx: StepContext) -> list[Event]:
        """Let every logger close what is open; returns the events (already emitted)."""
        out: list[Event] = []
        for reg in self._loggers:
            out.extend(reg.logger.finish(ctx))
        self.emit(out)
        return out

    def emit(self, events: Iterable[Event]) -> None:
        """Send events to every sink (also for events not produced by a logger)."""
        for event in events:
            for sink in self._sinks:
                key = id(sink)
                if key in self._errors:
                    self._lost[key] += 1
                    continue
                try:
                    sink.emit(event)
                except Exception as exc:  # a broken sink must not end the simulation
                    self._errors[key] = f"{type(exc).__name__}: {exc}"
                    self._lost[key] = 1

    def close(self) -> list[SinkReport]:
        """Close every sink once; a sink that failed reports its error in ``note``."""
        if self._closed:
            return []
        self._closed = True
        reports = []
        for sink in self._sinks:
            report = sink.close()
            error = self._errors.get(id(sink))
            if error is not None:
                report = report._replace(
                    dropped=report.dropped + self._lost[id(sink)], note=f"failed: {error}"
                )
            reports.append(report)
        return reports
