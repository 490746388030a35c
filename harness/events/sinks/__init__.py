"""Sinks: where events go. Found by name through the ``harness.sinks`` entry-point group.

Built in (also available without installed entry points): ``recording``
(:class:`RecordingSink`), ``jsonl`` (:class:`JsonLinesSink`), ``logging``
(:class:`LoggingSink`), ``seq`` (:class:`SeqSink`), ``collect`` (:class:`CollectingSink`).
A third-party sink is a class (or factory) taking keyword options and returning a
:class:`Sink`, registered as ``[project.entry-points."harness.sinks"] name = "pkg.mod:Class"``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any

from harness.events.errors import LoggerConfigError
from harness.events.sinks.base import Sink, SinkReport
from harness.events.sinks.collect import CollectingSink
from harness.events.sinks.jsonl import JsonLinesSink
from harness.events.sinks.recording import EventRecorder, RecordingSink
from harness.events.sinks.seq import SeqSink, to_clef
from harness.events.sinks.stdlog import LoggingSink

__all__ = [
    "ENTRY_POINT_GROUP",
    "CollectingSink",
    "EventRecorder",
    "JsonLinesSink",
    "LoggingSink",
    "RecordingSink",
    "SeqSink",
    "Sink",
    "SinkReport",
    "available_sinks",
    "create_sink",
    "to_clef",
]

ENTRY_POINT_GROUP = "harness.sinks"

_BUILTIN = {
    "collect": "harness.events.sinks.collect:CollectingSink",
    "jsonl": "harness.events.sinks.jsonl:JsonLinesSink",
    "logging": "harness.events.sinks.stdlog:LoggingSink",
    "recording": "harness.events.sinks.recording:RecordingSink",
    "seq": "harness.events.sinks.seq:SeqSink",
}


def _targets() -> dict[str, str]:
    found = dict(_BUILTIN)
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        found[ep.name] = ep.value
    return found


def available_sinks() -> list[str]:
    """Names :func:`create_sink` accepts (built-ins and installed entry points)."""
    return sorted(_targets())


def _load(target: str) -> Callable[..., Any]:
    module, _, attr = target.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    if not callable(obj):
        raise LoggerConfigError(f"sink entry point {target!r} is not callable")
    return obj  # type: ignore[no-any-return]


def create_sink(name: str, **options: Any) -> Sink:
    """Build the sink registered as ``name`` (case-insensitive) with keyword ``options``.

    Unknown names and options the sink does not take raise :class:`LoggerConfigError`.
    """
    targets = _targets()
    key = name.lower()
    if key not in targets:
        raise LoggerConfigError(f"unknown sink {name!r} (known: {', '.join(sorted(targets))})")
    factory = _load(targets[key])
    try:
        sink = factory(**options)
    except TypeError as exc:
        raise LoggerConfigError(f"sink {name!r}: {exc}") from None
    if not isinstance(sink, Sink):
        raise LoggerConfigError(f"sink {name!r} built a {type(sink).__name__}, not a Sink")
    return sink
