"""The scenario schema checked at the parameters' places only: what changes between examples.

Every example of a plan is the same document (the scenario with its parameters at their
nominal values: the *template*) with other values at the parameters' places; its keys and
list lengths are the template's. Checking the whole document against the scenario schema
for every example costs more than a millisecond (jsonschema walks all of it); where the
schema's verdict on the rest of the document cannot depend on the values, checking each value
against the subschemas that apply at its place gives the same verdict.

:class:`ValueChecker` finds those subschemas once, walking the schema along each parameter's
path in the template. The walk accepts only keywords whose verdict on an ancestor of a
parameter's place depends on the keys and lengths of the document, not on the values below
them (``properties``, ``additionalProperties``, ``items``, ``required``, local ``$ref``,
``not`` over ``required``, ...); any other keyword on the way (``anyOf``, ``enum``,
``uniqueItems``, ``if``, a remote ``$ref``, ...) and the checker declines: every example is
checked in full, as without it. A value that fails its subschemas is also checked in full, so
that the error is the schema's own, word for word.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from harness.explore.parameters import Parameter

__all__ = ["ValueChecker"]

_ANNOTATIONS = frozenset(
    {"$schema", "$id", "$defs", "$comment", "title", "description", "default", "examples",
     "deprecated", "readOnly", "writeOnly", "format"}
)  # fmt: skip
"""Keywords that never fail (``format`` asserts nothing without a format checker)."""

_STRUCTURE = frozenset(
    {"type", "required", "minProperties", "maxProperties", "propertyNames", "minItems",
     "maxItems", "dependentRequired"}
)  # fmt: skip
"""Keywords whose verdict on a container depends on its keys and length only (the values'
places do not change a container's type: it is the template's)."""

_DESCEND = frozenset({"properties", "additionalProperties", "items", "$ref", "not"})
"""Keywords the walk follows (``not``: only over structure keywords)."""


def _own(schema: Any) -> Any:
    """``schema`` without its ``$ref`` (the walk lists the referenced schema beside it), or
    None when nothing else of it can fail."""
    if not isinstance(schema, Mapping) or "$ref" not in schema:
        return schema
    rest = {k: v for k, v in schema.items() if k != "$ref"}
    return rest if set(rest) - _ANNOTATIONS else None


class _Decline(Exception):
    """The schema holds a keyword the walk cannot see past."""


class ValueChecker:
    """Checks examples' values against the subschemas at their places (see the module
    docstring). ``validator``: a jsonschema validator of the scenario schema (its resolver
    resolves the subschemas' local references); ``template``: the document every example
    shares, already valid; ``parameters``: the plan's."""

    def __init__(
        self, validator: Any, template: Mapping[str, Any], parameters: Sequence[Parameter]
    ) -> None:
        self._validator = validator
        self._root: Mapping[str, Any] = validator.schema
        self.places: dict[str, list[Any]] | None = None
        """Each parameter's subschemas (None: the checker declined)."""
        try:
            self._nested(parameters)
            self.places = {p.path: self._walk(template, p.tokens) for p in parameters}
        except _Decline:
            self.places = None
        self._checks = (
            None
            if self.places is None
            else {
                path: [validator.evolve(schema=s) for s in map(_own, schemas) if s is not None]
                for path, schemas in self.places.items()
            }
        )

    @property
    def active(self) -> bool:
        """Whether values are checked at their places (else every example in full)."""
        return self._checks is not None

    def valid(self, values: Mapping[str, Any]) -> bool:
        """True when every value passes the subschemas at its place (the example's document
        is schema-valid); False when one fails or the checker declined (check in full)."""
        if self._checks is None:
            return False
        return all(
            check.is_valid(values[path])
            for path, checks in self._checks.items()
            for check in checks
        )

    @staticmethod
    def _nested(parameters: Sequence[Parameter]) -> None:
        tokens = [p.tokens for p in parameters]
        for a in tokens:
            for b in tokens:
                if a is not b and len(a) <= len(b) and b[: len(a)] == a:
                    raise _Decline  # one value inside another: the inner one's place moves

    def _expand(self, schema: Any, seen: tuple[str, ...] = ()) -> list[Any]:
        """``schema`` and the schemas its ``$ref`` chain brings in (every one applies)."""
        if not isinstance(schema, Mapping):
            return [schema]  # True / False
        ref = schema.get("$ref")
        if ref is None:
            return [schema]
        if not isinstance(ref, str) or not ref.startswith("#/") or ref in seen:
            raise _Decline
        target: Any = self._root
        for part in ref[2:].split("/"):
            part = part.replace("~1", "/").replace("~0", "~")
            if not isinstance(target, Mapping) or part not in target:
                raise _Decline
            target = target[part]
        return [schema, *self._expand(target, (*seen, ref))]

    def _walk(self, template: Any, tokens: tuple[str | int, ...]) -> list[Any]:
        """The subschemas that apply at ``tokens`` in ``template``."""
        schemas = self._expand(self._root)
        node: Any = template
        for token in tokens:
            children: list[Any] = []
            for schema in schemas:
                if not isinstance(schema, Mapping):
                    if schema is False:
                        raise _Decline
                    continue
                for key in schema:
                    if key in _ANNOTATIONS or key in _STRUCTURE:
                        continue
                    if key not in _DESCEND:
                        raise _Decline
                not_ = schema.get("not")
                if not_ is not None and (
                    not isinstance(not_, Mapping) or not set(not_) <= _STRUCTURE
                ):
                    raise _Decline
                children.extend(self._child(schema, node, token))
            in_map = isinstance(node, Mapping) and isinstance(token, str) and token in node
            in_list = isinstance(node, list) and isinstance(token, int) and token < len(node)
            if not (in_map or in_list):
                raise _Decline  # not the template's structure
            node = node[token]
            schemas = [s for child in children for s in self._expand(child)]
        return schemas

    @staticmethod
    def _child(schema: Mapping[str, Any], node: Any, token: str | int) -> list[Any]:
        """The subschema(s) ``schema`` applies to ``node[token]``."""
        if isinstance(node, Mapping):
            properties = schema.get("properties")
            if isinstance(properties, Mapping) and token in properties:
                return [properties[token]]
            if "additionalProperties" in schema:
                return [schema["additionalProperties"]]
            return []
        if isinstance(node, list):
            items = schema.get("items", True)
            if not isinstance(items, Mapping | bool):
                raise _Decline  # an array of schemas: not 2020-12's items
            return [items]
        raise _Decline
