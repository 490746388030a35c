"""The type registry: ROS 2 message, service and action definitions by name.

Messages come from a rosbags typestore (Humble by default, any :class:`Stores` selectable);
services and actions, which rosbags' stores lack, are parsed from ``.srv``/``.action`` text
(bundled ones in ``interfaces/``, ``harness_msgs`` and whatever the user registers). Each
definition is compiled once into :class:`MessageDef` records the converters walk.
"""

from __future__ import annotations

import ast
import copy
import re
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, NamedTuple

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from harness.rosbridge.errors import TypeNameError, UnknownTypeError

__all__ = [
    "FLOAT_TYPES",
    "INT_RANGES",
    "ActionDef",
    "Field",
    "MessageDef",
    "ServiceDef",
    "TypeRegistry",
    "parse_type_name",
]

INT_RANGES: dict[str, tuple[int, int]] = {
    "byte": (0, 255),
    "char": (0, 255),
    "uint8": (0, 2**8 - 1),
    "uint16": (0, 2**16 - 1),
    "uint32": (0, 2**32 - 1),
    "uint64": (0, 2**64 - 1),
    "int8": (-(2**7), 2**7 - 1),
    "int16": (-(2**15), 2**15 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "int64": (-(2**63), 2**63 - 1),
}
FLOAT_TYPES = frozenset({"float32", "float64"})
# The member ROS 2 adds to empty structures; it never appears in JSON.
_EMPTY_MEMBER = "structure_needs_at_least_one_member"
_IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_KINDS = ("msg", "srv", "action")
_BOOLS = {"true": True, "false": False, "1": True, "0": False}
# rosbags' typestores drop the default values of field definitions; these are the non-zero
# ones of the ROS 2 definitions the stores hold (geometry_msgs/msg/Quaternion.msg: w 1).
_STORE_DEFAULTS: dict[str, dict[str, Any]] = {"geometry_msgs/msg/Quaternion": {"w": 1.0}}


class Field(NamedTuple):
    """One field: ``type`` is a primitive name or a full message name (``is_message``);
    ``length`` is None for a scalar, else the array length (``fixed``) or sequence bound
    (0 = unbounded); ``string_bound`` bounds ``string<=N``; ``default`` is the default value
    the definition declares (``float64 w 1``), None when it declares none."""

    name: str
    type: str
    is_message: bool
    length: int | None
    fixed: bool
    string_bound: int
    default: Any = None


class MessageDef(NamedTuple):
    """A compiled message definition: fields in definition order and constants."""

    name: str
    fields: tuple[Field, ...]
    constants: tuple[tuple[str, str, Any], ...]


class ServiceDef(NamedTuple):
    """A service: the message names of its request and response."""

    name: str
    request: str
    response: str


class ActionDef(NamedTuple):
    """An action: the message names of its goal, result and feedback."""

    name: str
    goal: str
    result: str
    feedback: str


def parse_type_name(text: object, kind: str = "msg") -> tuple[str, str]:
    """``(package, Type)`` from ``pkg/Type``, ``pkg/<kind>/Type`` or with stray slashes
    (``/std_msgs//String/``), as the reference accepts; :class:`TypeNameError` otherwise."""
    if not isinstance(text, str):
        raise TypeNameError(f"Invalid {kind} type {text!r}: expected a string")
    return _parse_type_name(text, kind)


@lru_cache(maxsize=1024)
def _parse_type_name(text: str, kind: str) -> tuple[str, str]:
    """:func:`parse_type_name` of a string, kept (a session resolves the same few dozen
    names at its start; a name that does not parse raises and is not kept)."""
    parts = [p for p in text.split("/") if p]
    if len(parts) == 3 and parts[1] == kind:
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(_IDENT.match(p) for p in parts):
        raise TypeNameError(f"Invalid {kind} type {text!r}: expected pkg/Type or pkg/{kind}/Type")
    return parts[0], parts[1]


def _split_sections(text: str, count: int, what: str) -> list[str]:
    sections: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            sections.append([])
        else:
            sections[-1].append(line)
    if len(sections) != count:
        raise TypeNameError(f"{what}: expected {count} sections separated by '---'")
    return ["\n".join(s) + "\n" for s in sections]


_TEMPLATES: dict[tuple[Stores, bool, bool], TypeRegistry] = {}
"""A built registry per (store, bundled, harness_msgs): every session builds one of the same
bundled definitions, so later ones start as a copy (building one generates a class per
definition: ~0.1 s, ``harness explore`` starts hundreds of sessions)."""


class TypeRegistry:
    """Message, service and action definitions known to one bridge.

    ``store`` selects the rosbags typestore; the bundled ``std_srvs``, ``example_interfaces``
    and ``rosapi_msgs`` interfaces and ``harness_msgs`` are registered unless disabled.
    """

    def __init__(
        self, store: Stores = Stores.ROS2_HUMBLE, *, bundled: bool = True, harness_msgs: bool = True
    ) -> None:
        key = (store, bundled, harness_msgs)
        template = _TEMPLATES.get(key)
        if template is not None:
            self._copy_of(template)
            return
        self.store = get_typestore(store)
        self._template: TypeRegistry | None = None
        self._compiled: dict[str, MessageDef] = {}
        self._services: dict[str, ServiceDef] = {}
        self._actions: dict[str, ActionDef] = {}
        self._texts: dict[str, str] = {}
        self._defaults: dict[str, dict[str, str]] = {}
        self._build(bundled, harness_msgs)
        made = TypeRegistry.__new__(TypeRegistry)
        made._copy_of(self)
        made._template = None
        _TEMPLATES[key] = made

    def _copy_of(self, other: TypeRegistry) -> None:
        """This registry as a copy of ``other`` (its own dicts and typestore: registering
        here never changes ``other``; the generated message classes are shared, immutable)."""
        self.store = copy.copy(other.store)
        self.store.types = dict(other.store.types)
        self.store.fielddefs = dict(other.store.fielddefs)
        self.store.cache = dict(other.store.cache)
        self._compiled = dict(other._compiled)
        self._services = dict(other._services)
        self._actions = dict(other._actions)
        self._texts = dict(other._texts)
        self._defaults = {k: dict(v) for k, v in other._defaults.items()}
        self._template = other

    def _build(self, bundled: bool, harness_msgs: bool) -> None:
        if bundled:
            root = resources.files("harness.rosbridge") / "interfaces"
            for pkg in sorted(root.iterdir(), key=lambda e: e.name):
                if not pkg.is_dir():
                    continue
                for kind in _KINDS:
                    folder = pkg / kind
                    if not folder.is_dir():
                        continue
                    # messages first: services of the same package refer to them
                    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
                        stem, _, ext = entry.name.rpartition(".")
                        if ext == kind:
                            self.register(f"{pkg.name}/{kind}/{stem}", entry.read_text("utf-8"))
        if harness_msgs:
            from harness.msgs import message_definitions, service_definitions

            for name, text in {**message_definitions(), **service_definitions()}.items():
                self.register(name, text)

    # -- registration -------------------------------------------------------------------

    def register(self, name: str, text: str) -> str:
        """Register ``pkg/msg/T``, ``pkg/srv/T`` or ``pkg/action/T`` from its definition
        text; returns the full name."""
        parts = [p for p in name.split("/") if p]
        if len(parts) != 3 or parts[1] not in _KINDS:
            raise TypeNameError(f"Cannot register {name!r}: expected pkg/msg|srv|action/Type")
        pkg, kind, typ = parts
        full = f"{pkg}/{kind}/{typ}"
        if kind == "msg":
            self._add_msg(f"{pkg}/msg/{typ}", text, full)
        elif kind == "srv":
            req, resp = _split_sections(text, 2, full)
            self._add_msg(f"{pkg}/msg/{typ}_Request", req, f"{full}_Request")
            self._add_msg(f"{pkg}/msg/{typ}_Response", resp, f"{full}_Response")
            self._services[full] = ServiceDef(full, f"{full}_Request", f"{full}_Response")
        else:
            goal, result, feedback = _split_sections(text, 3, full)
            self._add_msg(f"{pkg}/msg/{typ}_Goal", goal, f"{full}_Goal")
            self._add_msg(f"{pkg}/msg/{typ}_Result", result, f"{full}_Result")
            self._add_msg(f"{pkg}/msg/{typ}_Feedback", feedback, f"{full}_Feedback")
            self._actions[full] = ActionDef(
                full, f"{full}_Goal", f"{full}_Result", f"{full}_Feedback"
            )
        self._texts[full] = text
        return full

    def register_file(self, path: str | Path) -> str:
        """Register ``<pkg>/<msg|srv|action>/<Type>.<ext>`` (the package is the grandparent
        folder's name, as in a ROS package)."""
        p = Path(path)
        kind = p.suffix.lstrip(".")
        if kind not in _KINDS:
            raise TypeNameError(f"{p}: expected a .msg, .srv or .action file")
        return self.register(f"{p.parent.parent.name}/{kind}/{p.stem}", p.read_text("utf-8"))

    def _add_msg(self, parse_name: str, text: str, full: str) -> None:
        # rosbags resolves relative field types against the name's package; parse as
        # pkg/msg/X so that works for .srv/.action sections too, then store under `full`.
        try:
            ((_, (consts, fields)),) = get_types_from_msg(text, parse_name).items()
        except Exception as exc:  # rosbags raises its own parse error types
            raise TypeNameError(f"{full}: cannot parse definition: {exc}") from None
        self.store.register({full: (consts, fields)})
        self._compiled.pop(full, None)
        self._texts[full] = text
        self._defaults[full] = _declared_defaults(text)
        try:
            self.message(full)  # a default that does not fit its field fails here, not later
        except TypeNameError:
            del self._defaults[full]  # the fields stay usable, without the bad defaults
            raise

    # -- lookup -------------------------------------------------------------------------

    def resolve_message(self, text: object) -> str:
        """Full ``pkg/msg/Type`` for any accepted spelling; raises if invalid or unknown."""
        pkg, typ = parse_type_name(text, "msg")
        full = f"{pkg}/msg/{typ}"
        if full not in self.store.fielddefs:
            raise UnknownTypeError(f"Unknown message type {full}")
        return full

    def resolve_service(self, text: object) -> str:
        """Full ``pkg/srv/Type`` for any accepted spelling; raises if invalid or unknown."""
        pkg, typ = parse_type_name(text, "srv")
        full = f"{pkg}/srv/{typ}"
        if full not in self._services:
            raise UnknownTypeError(f"Unknown service type {full}")
        return full

    def resolve_action(self, text: object) -> str:
        """Full ``pkg/action/Type`` for any accepted spelling; raises if invalid or unknown."""
        pkg, typ = parse_type_name(text, "action")
        full = f"{pkg}/action/{typ}"
        if full not in self._actions:
            raise UnknownTypeError(f"Unknown action type {full}")
        return full

    def message(self, name: str) -> MessageDef:
        """The compiled definition of a full message name (or a service/action part)."""
        found = self._compiled.get(name)
        if found is not None:
            return found
        try:
            consts, raw_fields = self.store.fielddefs[name]
        except KeyError:
            raise UnknownTypeError(f"Unknown message type {name}") from None
        fields = []
        for fname, desc in raw_fields:
            if fname == _EMPTY_MEMBER:
                continue
            node: Any = desc[0]
            rest: Any = desc[1]
            count: int | None = None
            fixed = node == Nodetype.ARRAY
            if node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                (node, rest), count = rest
            if node == Nodetype.NAME:
                fields.append(Field(fname, str(rest), True, count, fixed, 0))
            else:
                typ, bound = rest
                fields.append(Field(fname, str(typ), False, count, fixed, int(bound)))
        declared = self._defaults.get(name)
        if declared is not None:
            fields = [
                f._replace(default=_default_value(name, f, declared[f.name]))
                if f.name in declared
                else f
                for f in fields
            ]
        else:
            known = _STORE_DEFAULTS.get(name, {})
            fields = [f._replace(default=known.get(f.name)) for f in fields]
        compiled = MessageDef(name, tuple(fields), tuple((c[0], c[1], c[2]) for c in consts))
        self._compiled[name] = compiled
        template = self._template
        if (
            template is not None
            and template.store.fielddefs.get(name) is self.store.fielddefs[name]
            and template._defaults.get(name) == declared
        ):
            # the template's own definition (not one registered here since the copy): the
            # next registries copied from it start with it compiled (every session compiles
            # the same dozen at its start)
            template._compiled.setdefault(name, compiled)
        return compiled

    def service(self, name: str) -> ServiceDef:
        """The service definition of a full service name."""
        try:
            return self._services[name]
        except KeyError:
            raise UnknownTypeError(f"Unknown service type {name}") from None

    def action(self, name: str) -> ActionDef:
        """The action definition of a full action name."""
        try:
            return self._actions[name]
        except KeyError:
            raise UnknownTypeError(f"Unknown action type {name}") from None

    def dependencies(self, name: str) -> list[str]:
        """``name`` and every message type it contains, depth first, each once."""
        seen: list[str] = []

        def visit(n: str) -> None:
            if n in seen:
                return
            seen.append(n)
            for f in self.message(n).fields:
                if f.is_message:
                    visit(f.type)

        visit(name)
        return seen

    def definition_text(self, name: str) -> str:
        """The full definition text of a message, nested definitions appended after
        ``====`` separators as in ROS 2's ``typedefs_full_text``."""
        parts = []
        for dep in self.dependencies(name):
            text = self._texts.get(dep)
            if text is None:
                text = "".join(
                    f"{_field_type_text(f)} {f.name}\n" for f in self.message(dep).fields
                )
            if dep != name:
                text = "=" * 80 + f"\nMSG: {dep}\n" + text
            parts.append(text if text.endswith("\n") else text + "\n")
        return "".join(parts)


def _field_type_text(f: Field) -> str:
    base = f.type
    if f.string_bound:
        base += f"<={f.string_bound}"
    if f.length is None:
        return base
    if f.fixed:
        return f"{base}[{f.length}]"
    return f"{base}[<={f.length}]" if f.length else f"{base}[]"


def _declared_defaults(text: str) -> dict[str, str]:
    """``field -> default text`` of the fields of a ``.msg`` text that declare a default
    (``TYPE NAME DEFAULT``; constants ``TYPE NAME=VALUE`` are not fields)."""
    out: dict[str, str] = {}
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split(None, 2)
        if len(parts) < 3 or "=" in parts[1] or parts[2].startswith("="):
            continue
        rest = parts[2]
        if rest[0] in "\"'":
            end = rest.find(rest[0], 1)
            while end > 0 and rest[end - 1] == "\\":
                end = rest.find(rest[0], end + 1)
            value = rest[: end + 1] if end > 0 else rest
        else:
            value = rest.split("#", 1)[0].strip()
        if value:
            out[parts[1]] = value
    return out


def _default_value(msg: str, f: Field, text: str) -> Any:
    """The typed value of a declared default; :class:`TypeNameError` when it does not fit."""
    try:
        if f.length is not None:
            items = ast.literal_eval(re.sub(r"\b(true|false)\b", lambda m: m[0].title(), text))
            if not isinstance(items, (list, tuple)):
                raise ValueError("not a list")
            values = [_scalar_default(f, repr(v) if isinstance(v, str) else str(v)) for v in items]
            if f.fixed and len(values) != f.length:
                raise ValueError(f"{len(values)} values for {f.length}")
            return bytes(values) if f.type in ("uint8", "char") else values
        return _scalar_default(f, text)
    except (ValueError, SyntaxError) as exc:
        raise TypeNameError(
            f"{msg}: default {text!r} of field {f.name} is not a valid {_field_type_text(f)}: {exc}"
        ) from None


def _scalar_default(f: Field, text: str) -> Any:
    if f.type in FLOAT_TYPES:
        return float(text)
    if f.type in INT_RANGES:
        value = int(text, 0)
        lo, hi = INT_RANGES[f.type]
        if not lo <= value <= hi:
            raise ValueError("out of range")
        return value
    if f.type == "bool":
        key = text.lower()
        if key not in _BOOLS:
            raise ValueError("expected true or false")
        return _BOOLS[key]
    if f.type in ("string", "wstring"):
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
            value = ast.literal_eval(text)
            if not isinstance(value, str):
                raise ValueError("not a string")
            return value
        return text
    raise ValueError("messages take no default")
