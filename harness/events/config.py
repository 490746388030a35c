"""The original scene config's ``logging`` section, honoured.

```json
"logging": {"enable": true, "frequency": 1,
            "destination": {"type": "Seq", "endpoint": "http://localhost:5341", "apiKey": "..."}}
```

``frequency`` is the joint logger's rate in Hz of *simulation* time. As a superset,
``destination`` may also be a list, and ``type`` any sink name (``jsonl``, ``logging``, ...)
whose other keys are that sink's options. Every other key is rejected with its key path.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from harness.events.errors import LoggerConfigError
from harness.events.sinks import Sink, available_sinks, create_sink
from harness.events.sinks.seq import clef_url

__all__ = ["DEFAULT_FREQUENCY_HZ", "LoggingConfig", "SinkSpec", "logging_config_from_scene"]

DEFAULT_FREQUENCY_HZ = 1.0
"""The original framework's joint-logging rate (there: about once per wall-clock second)."""

_SECTION_KEYS = ("enable", "frequency", "destination")
_SEQ_KEYS = ("type", "endpoint", "apiKey")


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


def _fail(path: str, problem: str) -> LoggerConfigError:
    return LoggerConfigError(f"{path}: {problem}")


def _check_keys(section: Mapping[str, Any], allowed: Sequence[str], path: str) -> None:
    for key in section:
        if key not in allowed:
            raise _fail(f"{path}.{key}", f"unknown key (allowed: {', '.join(allowed)})")


def _destination(item: Any, path: str) -> SinkSpec:
    if not isinstance(item, Mapping):
        raise _fail(path, f"must be an object, got {type(item).__name__}")
    kind = item.get("type")
    if not isinstance(kind, str) or not kind:
        raise _fail(f"{path}.type", "required: a sink name such as 'Seq'")
    name = kind.lower()
    if name not in available_sinks():
        raise _fail(
            f"{path}.type", f"unknown sink {kind!r} (known: {', '.join(available_sinks())})"
        )
    if name != "seq":
        return SinkSpec(name, tuple((k, v) for k, v in item.items() if k != "type"))
    _check_keys(item, _SEQ_KEYS, path)
    endpoint = item.get("endpoint", "http://localhost:5341")
    if not isinstance(endpoint, str):
        raise _fail(f"{path}.endpoint", f"must be a URL string, got {endpoint!r}")
    try:
        clef_url(endpoint)
    except LoggerConfigError:
        raise _fail(f"{path}.endpoint", f"must be an http(s) URL, got {endpoint!r}") from None
    options: list[tuple[str, Any]] = [("endpoint", endpoint)]
    if "apiKey" in item:
        key = item["apiKey"]
        if not isinstance(key, str):
            raise _fail(f"{path}.apiKey", "must be a string")
        options.append(("api_key", key))
    return SinkSpec("seq", tuple(options))


def logging_config_from_scene(section: Any, *, path: str = "logging") -> LoggingConfig:
    """Parse the scene config's ``logging`` section (``path``: its key path, for messages).

    Raises :class:`LoggerConfigError` naming the key path of the first bad value.
    """
    if not isinstance(section, Mapping):
        raise _fail(path, f"must be an object, got {type(section).__name__}")
    _check_keys(section, _SECTION_KEYS, path)
    enable = section.get("enable", True)
    if not isinstance(enable, bool):
        raise _fail(f"{path}.enable", f"must be true or false, got {enable!r}")
    frequency = section.get("frequency", DEFAULT_FREQUENCY_HZ)
    if (
        isinstance(frequency, bool)
        or not isinstance(frequency, (int, float))
        or not math.isfinite(frequency)
        or frequency <= 0
    ):
        raise _fail(f"{path}.frequency", f"must be a positive number (Hz), got {frequency!r}")
    raw = section.get("destination", [])
    items = raw if isinstance(raw, list) else [raw]
    if isinstance(raw, list):
        specs = tuple(
            _destination(item, f"{path}.destination[{i}]") for i, item in enumerate(items)
        )
    else:
        specs = (_destination(raw, f"{path}.destination"),)
    return LoggingConfig(enable=enable, frequency_hz=float(frequency), destinations=specs)
