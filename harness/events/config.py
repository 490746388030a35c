"""The original scene config's ``logging`` section, honoured.

```json
"logging": {"enable": true, "frequency": 1,
            "destination": {"type": "Seq", "endpoint": "http://localhost:5341", "apiKey": "..."}}
```

``frequency`` is the joint logger's rate in Hz of *simulation* time. As a superset,
``destination`` may also be a list, and ``type`` any sink name (``JsonLines``/``jsonl``,
``Logging``, a registered entry point, ...) whose other keys are that sink's options. The Seq
API key is ``api_key`` (our spelling) or ``apiKey`` (the original's).

One validator: :data:`LOGGING_SCHEMA` (``logging.schema.json``, which the scenario schema
references for its ``logging`` key) is the only description of the keys; this module checks
only what a schema cannot (the sink name is registered) and builds :class:`LoggingConfig`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from harness.events.errors import LoggerConfigError
from harness.events.sinks import Sink, available_sinks, create_sink
from harness.validation import format_path, schema_problems

__all__ = [
    "DEFAULT_FREQUENCY_HZ",
    "LOGGING_SCHEMA",
    "LoggingConfig",
    "SinkSpec",
    "logging_config_from_scene",
]

DEFAULT_FREQUENCY_HZ = 1.0
"""The original framework's joint-logging rate (there: about once per wall-clock second)."""

LOGGING_SCHEMA: dict[str, Any] = json.loads(
    resources.files("harness.events").joinpath("logging.schema.json").read_text("utf-8")
)
"""The JSON Schema of the ``logging`` section (``$id`` ends in ``logging.schema.json``)."""

_SINK_NAMES = {"jsonlines": "jsonl"}  # the scenario files' type names -> registered sink names
_OPTION_NAMES = {"apiKey": "api_key"}  # the original's camelCase -> our keyword


@dataclass(frozen=True)
class SinkSpec:
    """A sink by registered name with its keyword options."""

    name: str
    options: tuple[tuple[str, Any], ...] = ()

    def create(self) -> Sink:
        """Build the sink (:func:`harness.events.sinks.create_sink`)."""
        return create_sink(self.name, **dict(self.options))


@dataclass(frozen=True)
class LoggingConfig:
    """What the ``logging`` section asks for. ``enable`` False: no joint logger and no
    destinations (the recording sink is always on regardless)."""

    enable: bool = True
    frequency_hz: float = DEFAULT_FREQUENCY_HZ
    destinations: tuple[SinkSpec, ...] = ()

    def create_sinks(self) -> list[Sink]:
        """The destination sinks (none when disabled)."""
        return [spec.create() for spec in self.destinations] if self.enable else []


def _destination(item: Mapping[str, Any], path: list[str | int], base: Path | None) -> SinkSpec:
    kind = str(item["type"])
    name = _SINK_NAMES.get(kind.lower(), kind.lower())
    if name not in available_sinks():
        raise LoggerConfigError(
            f"{format_path([*path, 'type'])}: unknown sink {kind!r} "
            f"(known: Seq, JsonLines, Logging, {', '.join(available_sinks())})"
        )
    options: dict[str, Any] = {}
    for key, value in item.items():
        if key == "type":
            continue
        if key == "path" and base is not None:
            value = str((base / str(value)).resolve())
        options[_OPTION_NAMES.get(key, key)] = value
    return SinkSpec(name, tuple(options.items()))


def logging_config_from_scene(
    section: Any, *, path: str = "logging", base_dir: Path | None = None
) -> LoggingConfig:
    """Validate the scene config's ``logging`` section against :data:`LOGGING_SCHEMA` and
    build it (``path``: its key path, for messages; ``base_dir``: where relative sink paths
    resolve). Raises :class:`LoggerConfigError` listing every problem with its key path."""
    where, _, key = path.rpartition(": ")
    prefix: list[str | int] = [key or path]
    problems = schema_problems(section, LOGGING_SCHEMA, where, path=prefix)
    frequency = section.get("frequency") if isinstance(section, Mapping) else None
    if isinstance(frequency, float) and not math.isfinite(frequency):  # not JSON: no schema
        problems.append(f"{format_path([*prefix, 'frequency'])}: must be a finite number")
    if problems:
        raise LoggerConfigError("; ".join(problems))
    raw = section.get("destination", [])
    items = raw if isinstance(raw, list) else [raw]
    specs = tuple(
        _destination(
            item, [*prefix, "destination", *([i] if isinstance(raw, list) else [])], base_dir
        )
        for i, item in enumerate(items)
    )
    return LoggingConfig(
        enable=section.get("enable", True),
        frequency_hz=float(section.get("frequency", DEFAULT_FREQUENCY_HZ)),
        destinations=specs,
    )
