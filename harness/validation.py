"""Validation against the shipped JSON Schemas: every violation as one line naming the source,
the key path (``robots[0].position``) and the offending value; "additional property" errors
become "unknown key ... (did you mean ...?)".

One validator per file format: the scenario schema (:mod:`harness.scenario`) and the logging
section's schema (:mod:`harness.events`, referenced by the scenario schema) are the only
descriptions of their keys; the code behind them checks only what a schema cannot.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import jsonschema  # type: ignore[import-untyped]
import referencing

__all__ = ["format_path", "schema_problems", "validator"]


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


def _at(source: str, path: list[str | int]) -> str:
    return f"{source}: {format_path(path)}" if source else format_path(path)


def _describe(error: Any, source: str, prefix: list[str | int]) -> list[str]:
    path = [*prefix, *error.absolute_path]
    where = _at(source, path)
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
            lines.append(f"{_at(source, [*path, key])}: unknown key{hint}")
        return lines
    if error.validator == "not" and set(error.validator_value) == {"required"}:
        keys = " and ".join(repr(k) for k in error.validator_value["required"])
        return [f"{where}: give only one of {keys} (two spellings of one option)"]
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
        # Explain with the deepest problem of a branch the value's shape fits: a key inside
        # an object (deeper than the value) before a mismatch of the value's own type.
        subs = list(error.context or ())
        deeper = [s for s in subs if len(s.absolute_path) > len(error.absolute_path)]
        if deeper:
            return _describe(max(deeper, key=lambda s: len(s.absolute_path)), source, prefix)
        for sub in subs:
            if sub.validator != "type":
                return _describe(sub, source, prefix)
        kinds = [str(s.get("type", "?")) for s in error.validator_value]
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


def validator(schema: Mapping[str, Any], resources: Iterable[Mapping[str, Any]] = ()) -> Any:
    """A Draft 2020-12 validator of ``schema``; ``resources``: the schemas (each with its
    ``$id``) it references."""
    registry: referencing.Registry[Any] = referencing.Registry().with_resources(
        (str(r["$id"]), referencing.Resource.from_contents(dict(r))) for r in resources
    )
    return jsonschema.Draft202012Validator(dict(schema), registry=registry)


def schema_problems(
    document: Any,
    schema: Mapping[str, Any],
    source: str,
    *,
    path: Sequence[str | int] = (),
    resources: Iterable[Mapping[str, Any]] = (),
) -> list[str]:
    """Every violation of ``schema`` in ``document``, one line each, in key order.

    ``path``: where ``document`` sits in its file (prefixed to every key path);
    ``resources``: other schemas (each with its ``$id``) that ``schema`` references."""
    errors: Sequence[Any] = sorted(
        validator(schema, resources).iter_errors(document),
        key=lambda e: [str(p) for p in e.absolute_path],
    )
    problems: list[str] = []
    for error in errors:
        problems.extend(_describe(error, source, list(path)))
    return problems
