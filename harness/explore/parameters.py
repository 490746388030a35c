"""The ``explore.parameters`` of a scenario: what may vary, by the scenario's own keys.

A parameter's path is dotted: mapping keys by name, list entries by index or, for lists of
named entries (``objects``, ``robots``, ``sensors``), by ``name`` (``objects.obstacle.size``,
``robots.0.initial_joint_positions.joint2``, ``client.env.TARGET_X``, ``script.1.at``, ``seed``).
``initial_positions`` is accepted for ``initial_joint_positions``. Each parameter is a range
(``low``/``high``: a number, or a list as long as the value), ``choices`` (a list), or
``integers`` (``[low, high]``, inclusive).

The *nominal* value is the scenario's value as written (clipped into the range; the range's
low end, or the first choice, when the file does not give the key). Values are drawn as
nominal + delta, so that hypothesis, shrinking each delta toward zero, shrinks an example
toward the scenario as written rather than toward zero or a bound.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from harness.explore.errors import ExploreConfigError

__all__ = [
    "ALIASES",
    "Parameter",
    "apply_values",
    "parse_parameters",
]

ALIASES = {"initial_positions": "initial_joint_positions"}
"""Path components accepted for the scenario's own key."""

Kind = Literal["range", "choices", "integers"]


@dataclass(frozen=True)
class Parameter:
    """One varying scenario key. ``tokens``: the path resolved to keys and list indices of the
    document; ``low``/``high``: per-component bounds of a range (one component for a scalar;
    ``vector`` tells a list value from a scalar); ``choices``: the values of a choice, the
    nominal first; ``nominal``: the value as written (see the module docstring)."""

    path: str
    tokens: tuple[str | int, ...]
    kind: Kind
    nominal: Any
    low: tuple[float, ...] = ()
    high: tuple[float, ...] = ()
    vector: bool = False
    choices: tuple[Any, ...] = ()

    def labels(self) -> list[str]:
        """Names of the plottable components: ``path`` or ``path[i]`` per component."""
        if self.kind == "range" and self.vector:
            return [f"{self.path}[{i}]" for i in range(len(self.low))]
        return [self.path]

    def components(self, value: Any) -> list[float | None]:
        """The numeric components of a value (None for a non-numeric choice)."""
        if self.kind == "range" and self.vector:
            return [float(v) for v in value]
        if isinstance(value, bool) or not isinstance(value, int | float):
            try:
                return [float(value)]
            except (TypeError, ValueError):
                return [None]
        return [float(value)]

    def value_of(self, delta: Any) -> Any:
        """The parameter's value for a drawn ``delta`` (a choice is drawn as itself)."""
        if self.kind == "choices":
            return delta
        if self.kind == "integers":
            return int(self.nominal) + int(delta)
        values = [
            min(max(n + d, lo), hi)
            for n, d, lo, hi in zip(
                self._nominals(),
                delta if self.vector else [delta],
                self.low,
                self.high,
                strict=True,
            )
        ]
        return values if self.vector else values[0]

    def _nominals(self) -> list[float]:
        return [float(v) for v in self.nominal] if self.vector else [float(self.nominal)]


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


class _Parser:
    def __init__(self, doc: Mapping[str, Any], where: str) -> None:
        self.doc = doc
        self.where = where

    def fail(self, path: str, text: str) -> ExploreConfigError:
        return ExploreConfigError(f"{self.where}: explore.parameters.{path}: {text}")

    def resolve(self, path: str) -> tuple[tuple[str | int, ...], Any, bool]:
        """The path's tokens, the value there (None when absent) and whether it is present."""
        parts = path.split(".")
        if not path or any(not p for p in parts):
            raise self.fail(path, "is not a dotted key path (e.g. objects.box.position)")
        node: Any = self.doc
        tokens: list[str | int] = []
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            part = ALIASES.get(part, part)
            if isinstance(node, list):
                index = self._index(node, part, path, ".".join(parts[:i]))
                tokens.append(index)
                node = node[index]
                continue
            if not isinstance(node, dict):
                raise self.fail(
                    path, f"{'.'.join(parts[:i]) or 'the document'} holds no key {part!r}"
                )
            tokens.append(part)
            if part not in node:
                if last:
                    return tuple(tokens), None, False
                if part in ("env", "initial_joint_positions", "positions", "velocities"):
                    node = {}  # an absent mapping the value will create
                    continue
                raise self.fail(path, f"the scenario has no {'.'.join(parts[: i + 1])!r}")
            node = node[part]
        return tuple(tokens), node, True

    def _index(self, items: list[Any], part: str, path: str, where: str) -> int:
        if part.isdigit():
            if int(part) >= len(items):
                raise self.fail(path, f"{where} has {len(items)} entries (no index {part})")
            return int(part)
        for index, item in enumerate(items):
            if isinstance(item, dict) and item.get("name") == part:
                return index
        names = [str(x.get("name")) for x in items if isinstance(x, dict) and "name" in x]
        known = f" (its names: {', '.join(names)})" if names else ""
        raise self.fail(path, f"{where} has no entry named {part!r}{known}")

    def parameter(self, path: str, spec: Mapping[str, Any]) -> Parameter:
        tokens, current, present = self.resolve(path)
        kinds = [k for k in ("choices", "integers") if k in spec]
        if "low" in spec or "high" in spec:
            kinds.append("range")
        if len(kinds) != 1:
            raise self.fail(path, "give exactly one of low/high, choices or integers")
        kind = kinds[0]
        if kind == "choices":
            choices = list(spec["choices"])
            first = current if present and current in choices else choices[0]
            ordered = [first, *(c for c in choices if c != first)]
            return Parameter(path, tokens, "choices", first, choices=tuple(ordered))
        if kind == "integers":
            lo, hi = spec["integers"]
            if lo > hi:
                raise self.fail(path, f"integers: low {lo} is above high {hi}")
            start = current if present and isinstance(current, int) else lo
            return Parameter(path, tokens, "integers", min(max(start, lo), hi), (lo,), (hi,))
        if "low" not in spec or "high" not in spec:
            raise self.fail(path, "a range needs both low and high")
        low, high = spec["low"], spec["high"]
        vector = isinstance(low, list)
        if vector != isinstance(high, list):
            raise self.fail(path, "low and high must both be numbers or both lists")
        lows = [float(v) for v in (low if vector else [low])]
        highs = [float(v) for v in (high if vector else [high])]
        if len(lows) != len(highs):
            raise self.fail(path, f"low has {len(lows)} numbers, high {len(highs)}")
        for i, (lo, hi) in enumerate(zip(lows, highs, strict=True)):
            if lo > hi:
                raise self.fail(path, f"low {lo:g} is above high {hi:g} (component {i})")
        if present:
            if vector != isinstance(current, list) or (vector and len(current) != len(lows)):
                shape = f"a list of {len(lows)} numbers" if vector else "a number"
                raise self.fail(path, f"the scenario's value {current!r} is not {shape}")
            values = current if vector else [current]
            if not all(_number(v) for v in values):
                raise self.fail(path, f"the scenario's value {current!r} is not numeric")
            nominal_list = [
                min(max(float(v), lo), hi) for v, lo, hi in zip(values, lows, highs, strict=True)
            ]
        else:
            nominal_list = list(lows)
        nominal: Any = nominal_list if vector else nominal_list[0]
        return Parameter(path, tokens, "range", nominal, tuple(lows), tuple(highs), vector)


def parse_parameters(doc: Mapping[str, Any], where: str) -> tuple[Parameter, ...]:
    """The ``explore.parameters`` of a (schema-valid) scenario document; raises
    :class:`ExploreConfigError` naming the file and the parameter's path."""
    section = doc.get("explore")
    if not isinstance(section, Mapping) or not section.get("parameters"):
        raise ExploreConfigError(
            f"{where}: explore: the scenario has no explore.parameters section (what may vary)"
        )
    parser = _Parser(doc, where)
    return tuple(parser.parameter(path, spec) for path, spec in section["parameters"].items())


def apply_values(
    doc: Mapping[str, Any], parameters: Sequence[Parameter], values: Mapping[str, Any]
) -> dict[str, Any]:
    """A copy of ``doc`` with each parameter's value set and no ``explore`` section."""
    out: dict[str, Any] = {k: _copy(v, {}) for k, v in doc.items() if k != "explore"}
    for p in parameters:
        node: Any = out
        for token in p.tokens[:-1]:
            if isinstance(token, str) and token not in node:
                node[token] = {}
            node = node[token]
        node[p.tokens[-1]] = _copy(values[p.path], {})
    return out


_ATOMS = (str, int, float, bool, type(None))


def _copy(value: Any, memo: dict[int, Any]) -> Any:
    """``copy.deepcopy(value, memo)`` for a parsed document, faster (an example's cost): a
    container met twice (a YAML alias) is copied once, as deepcopy does; a type other than
    dict, list and the atoms goes to deepcopy."""
    kind = type(value)
    if kind in _ATOMS:
        return value
    done = memo.get(id(value))
    if done is not None:
        return done
    if kind is dict:
        out: dict[Any, Any] = {}
        memo[id(value)] = out
        for k, v in value.items():
            out[k if type(k) in _ATOMS else copy.deepcopy(k, memo)] = _copy(v, memo)
        return out
    if kind is list:
        items: list[Any] = []
        memo[id(value)] = items
        items.extend(_copy(v, memo) for v in value)
        return items
    return copy.deepcopy(value, memo)
