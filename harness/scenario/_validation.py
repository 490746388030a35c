"""Validation of configuration documents against the shipped JSON Schemas.

jsonschema finds every violation with its location; this module turns each one into a line
naming the file, the key path (``robots[0].position``) and the offending value, and turns
"additional property" errors into "unknown key ... (did you mean ...?)".
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Iterable, Sequence
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema  # type: ignore[import-untyped]
import yaml  # type: ignore[import-untyped,unused-ignore]

from harness.scenario.errors import ScenarioError

__all__ = [
    "MAX_DOCUMENT_BYTES",
    "MAX_DOCUMENT_VALUES",
    "format_path",
    "load_document",
    "schema",
    "schema_problems",
]

MAX_DOCUMENT_BYTES = 4 * 2**20
"""The largest scenario or runner file read (4 MiB; real ones are a few kB)."""
MAX_DOCUMENT_VALUES = 1_000_000
"""The most values a document may hold once YAML aliases are expanded (an alias "billion
laughs" is a few hundred bytes that validation would walk for hours)."""


def _check_expanded_size(data: Any, path: Path) -> None:
    count = 0
    stack = [data]
    while stack:
        item = stack.pop()
        count += 1
        if count > MAX_DOCUMENT_VALUES:
            raise ScenarioError(
                [
                    f"{path}: more than {MAX_DOCUMENT_VALUES:,} values once YAML aliases are "
                    "expanded (an alias bomb?)"
                ]
            )
        if isinstance(item, dict):
            stack.extend(item.keys())
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)


@cache
def schema(name: str) -> dict[str, Any]:
    """The shipped JSON Schema ``name`` ("scenario" or "runner")."""
    text = resources.files("harness.scenario").joinpath(f"{name}.schema.json").read_text("utf-8")
    loaded: dict[str, Any] = json.loads(text)
    return loaded


def load_document(path: Path) -> Any:
    """Parse a JSON or YAML file (by extension; YAML is a superset of JSON otherwise);
    files over :data:`MAX_DOCUMENT_BYTES` are refused before they are read."""
    try:
        size = path.stat().st_size
        if size > MAX_DOCUMENT_BYTES:
            raise ScenarioError(
                [
                    f"{path}: file is {size / 2**20:.1f} MiB, more than the "
                    f"{MAX_DOCUMENT_BYTES / 2**20:g} MiB limit for scenario and runner files"
                ]
            )
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError([f"{path}: no such file"]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError([f"{path}: cannot read: {exc}"]) from None
    try:
        if path.suffix.lower() == ".json":
            return json.loads(text)
        data = yaml.safe_load(text)
    except json.JSONDecodeError as exc:
        raise ScenarioError([f"{path}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}"]) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark is not None else str(path)
        problem = getattr(exc, "problem", None) or str(exc)
        raise ScenarioError([f"{where}: invalid YAML: {problem}"]) from None
    except RecursionError:
        raise ScenarioError([f"{path}: nested too deeply"]) from None
    _check_expanded_size(data, path)
    return data


def format_path(parts: Iterable[str | int]) -> str:
    """``["robots", 0, "position"]`` -> ``robots[0].position`` (``<root>`` when empty)."""
    out = ""
    for part in parts:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out or "<root>"


def _value(value: Any) -> str:
    text = json.dumps(value, default=str)
    return text if len(text) <= 60 else text[:57] + "..."


def _describe(error: Any, source: str) -> list[str]:
    path = list(error.absolute_path)
    where = f"{source}: {format_path(path)}"
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        known = sorted(error.schema.get("properties", {}))
        lines = []
        for key in error.instance:
            if key in known:
                continue
            guess = difflib.get_close_matches(str(key), known, n=1)
            hint = (
                f" (did you mean {guess[0]!r}?)" if guess else f" (known keys: {', '.join(known)})"
            )
            lines.append(f"{source}: {format_path([*path, key])}: unknown key{hint}")
        return lines
    if error.validator == "required":
        missing = error.message.split("'")[1] if "'" in error.message else error.message
        return [f"{where}: missing required key {missing!r}"]
    if error.validator == "enum":
        allowed = ", ".join(repr(v) for v in error.validator_value)
        return [f"{where}: {_value(error.instance)} is not one of {allowed}"]
    if error.validator == "const":
        return [f"{where}: {_value(error.instance)} must be {error.validator_value!r}"]
    if error.validator == "type":
        wanted = error.validator_value
        wanted = " or ".join(wanted) if isinstance(wanted, list) else wanted
        return [f"{where}: {_value(error.instance)} is not of type {wanted}"]
    if error.validator == "anyOf":
        # Explain with the branch whose type matches the value, when there is one.
        for sub in error.context or ():
            if sub.validator != "type":
                return _describe(sub, source)
        kinds = [s.get("type", "?") for s in error.validator_value]
        expected = " or ".join(kinds)
        return [f"{where}: {_value(error.instance)} is not a valid value (expected {expected})"]
    if error.validator == "exclusiveMinimum":
        return [f"{where}: {_value(error.instance)} must be greater than {error.validator_value}"]
    if error.validator == "minimum":
        return [f"{where}: {_value(error.instance)} must be at least {error.validator_value}"]
    if error.validator == "maximum":
        return [f"{where}: {_value(error.instance)} must be at most {error.validator_value}"]
    if error.validator in ("minItems", "maxItems"):
        return [f"{where}: {_value(error.instance)} has the wrong length ({error.message})"]
    if error.validator == "pattern":
        return [f"{where}: {_value(error.instance)} does not match {error.validator_value!r}"]
    return [f"{where}: {_value(error.instance)}: {error.message}"]


def schema_problems(document: Any, schema_name: str, source: str) -> list[str]:
    """Every violation of schema ``schema_name`` in ``document``, one line each, in key order."""
    validator = jsonschema.Draft202012Validator(schema(schema_name))
    errors: Sequence[Any] = sorted(
        validator.iter_errors(document), key=lambda e: [str(p) for p in e.absolute_path]
    )
    problems: list[str] = []
    for error in errors:
        problems.extend(_describe(error, source))
    return problems
