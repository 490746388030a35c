"""Reading scenario and runner documents, and validating them against the shipped JSON
Schemas (the messages: :mod:`harness.validation`)."""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import yaml  # type: ignore[import-untyped,unused-ignore]

from harness import validation, vocabulary
from harness.scenario.errors import ScenarioError
from harness.validation import format_path

__all__ = [
    "MAX_DOCUMENT_BYTES",
    "MAX_DOCUMENT_VALUES",
    "format_path",
    "load_document",
    "schema",
    "schema_problems",
    "validator",
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
    return vocabulary.apply_schema_enums(name, loaded)  # the enums are harness.vocabulary's


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


def validator(schema_name: str) -> Any:
    """A jsonschema validator of schema ``schema_name`` with the schemas it references."""
    from harness.events import LOGGING_SCHEMA

    return validation.validator(schema(schema_name), [LOGGING_SCHEMA])


def schema_problems(document: Any, schema_name: str, source: str) -> list[str]:
    """Every violation of schema ``schema_name`` in ``document``, one line each, in key order
    (the scenario schema's ``logging`` section is :data:`harness.events.LOGGING_SCHEMA`)."""
    from harness.events import LOGGING_SCHEMA

    return validation.schema_problems(
        document, schema(schema_name), source, resources=[LOGGING_SCHEMA]
    )
