"""JSON <-> ROS message conversion with rosbridge's encoding rules.

A *canonical* message is a plain dict in definition order with every field present: ints,
floats (non-finite allowed), bools, strings, nested dicts, lists, ``bytes`` for
``uint8[]``/``char[]`` and ``{"sec", "nanosec"}`` for time and duration. It is what the
in-process API hands out and takes, and what the encoders below turn into JSON text
(base64 bytes, NaN/Inf as null), CBOR (typed arrays) or CDR.
"""

from __future__ import annotations

import base64
import binascii
import functools
import json
import math
from collections.abc import Mapping
from typing import Any

import cbor2
import numpy as np

from harness.rosbridge.errors import ConversionError
from harness.rosbridge.types import FLOAT_TYPES, INT_RANGES, Field, MessageDef, TypeRegistry

__all__ = [
    "default_message",
    "dumps",
    "from_json",
    "publish_prefix",
    "to_cbor",
    "to_cdr",
]

_TIME_TYPES = frozenset({"builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"})
_HEADER = "std_msgs/msg/Header"
_BYTE_TYPES = frozenset({"uint8", "char"})
_CBOR_TAGS = {
    "uint16": (69, "<u2"),
    "uint32": (70, "<u4"),
    "uint64": (71, "<u8"),
    "int8": (72, "i1"),
    "int16": (77, "<i2"),
    "int32": (78, "<i4"),
    "int64": (79, "<i8"),
    "float32": (85, "<f4"),
    "float64": (86, "<f8"),
}
_NUMPY = {
    **{k: v[1] for k, v in _CBOR_TAGS.items()},
    "uint8": "u1",
    "char": "u1",
    "byte": "u1",
    "bool": "?",
}


_EMPTY_PLACEHOLDER = "structure_needs_at_least_one_member"
"""The member ROS 2's C/C++ code generators give an empty message: rosbridge servers that read
it from the type support (rosbridge-server-rs) send it; it carries nothing."""


def _describe(value: object) -> str:
    names = {bool: "a bool", int: "an int", float: "a float", str: "a string", list: "a list"}
    kind = names.get(type(value), "an object" if isinstance(value, dict) else "null")
    text = json.dumps(value, default=str)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{kind} ({text})"


def _fail(msg_type: str, expected: str, path: str, value: object) -> ConversionError:
    return ConversionError(
        f"{msg_type} message requires {expected} for field {path}, but got {_describe(value)}"
    )


def _zero(registry: TypeRegistry, f: Field) -> Any:
    """A field's value when a message omits it: the definition's default, else zero."""
    if f.default is not None:
        return list(f.default) if isinstance(f.default, list) else f.default
    if f.length is not None:
        if not f.fixed:
            return b"" if f.type in _BYTE_TYPES else []
        if f.type in _BYTE_TYPES:
            return bytes(f.length)
        return [_zero_scalar(registry, f) for _ in range(f.length)]
    return _zero_scalar(registry, f)


def _zero_scalar(registry: TypeRegistry, f: Field) -> Any:
    if f.is_message:
        return default_message(registry, f.type)
    return _zero_scalar_value(f)


def _zero_scalar_value(f: Field) -> Any:
    """A primitive scalar field's value when a message omits it (immutable)."""
    if f.default is not None:
        return f.default
    if f.type in INT_RANGES:
        return 0
    if f.type in FLOAT_TYPES:
        return 0.0
    if f.type == "bool":
        return False
    return ""


_DEFAULTS: dict[int, tuple[MessageDef, dict[str, Any], tuple[str, ...]]] = {}


def default_message(registry: TypeRegistry, msg_type: str) -> dict[str, Any]:
    """The canonical message of ``msg_type`` with every field at its default (the value
    the ROS 2 definition declares, else zero)."""
    definition = registry.message(msg_type)
    cached = _DEFAULTS.get(id(definition))
    if cached is None or cached[0] is not definition:
        # built once per definition, copied for every message (a message is the caller's)
        template = {f.name: _zero(registry, f) for f in definition.fields}
        mutable = tuple(k for k, v in template.items() if type(v) in (dict, list))
        cached = _DEFAULTS[id(definition)] = (definition, template, mutable)
    _, template, mutable = cached
    out = template.copy()
    for key in mutable:
        out[key] = _fresh(template[key])
    return out


def _fresh(value: Any) -> Any:
    """A copy of a canonical value sharing nothing mutable with it."""
    kind = type(value)
    if kind is dict:
        return {k: _fresh(v) for k, v in value.items()}
    if kind is list:
        return [_fresh(v) for v in value] if value else []
    return value  # immutable: numbers, strings, bytes, bools


def from_json(
    registry: TypeRegistry, msg_type: str, value: object, now_ns: int, path: str = ""
) -> dict[str, Any]:
    """Validate a JSON value against ``msg_type`` and return the canonical message.

    Missing fields take the definition's defaults (``geometry_msgs/msg/Quaternion`` w = 1.0),
    else zero; an unknown field or a wrong field type raises
    :class:`ConversionError` naming the field path and the types; a ``std_msgs/Header``
    given without ``stamp`` gets ``now_ns``."""
    if not isinstance(value, dict):
        where = f" for field {path}" if path else ""
        raise ConversionError(
            f"{msg_type} message requires an object{where}, but got {_describe(value)}"
        )
    if msg_type in _TIME_TYPES:
        return _time_from_json(msg_type, value, path)
    definition = registry.message(msg_type)
    known, plan = _plan(definition)
    for key in value:
        if key not in known and not (key == _EMPTY_PLACEHOLDER and not known):
            raise ConversionError(f"Message type {msg_type} does not have a field {path}{key}")
    out: dict[str, Any] = {}
    for f, name, kind, lo, hi, zero in plan:
        if name not in value:
            if msg_type == _HEADER and name == "stamp":
                out["stamp"] = {"sec": now_ns // 1_000_000_000, "nanosec": now_ns % 1_000_000_000}
            else:
                out[name] = _zero(registry, f) if zero is _MUTABLE else zero
            continue
        v = value[name]
        # the common valid cases inline (what _scalar returns for them), the rest below
        if (
            (kind == _KIND_FLOAT and type(v) is float)
            or (kind == _KIND_INT and type(v) is int and lo <= v <= hi)
            or (kind == _KIND_STR and type(v) is str)
        ):
            out[name] = v
        elif kind == _KIND_ARRAY:
            out[name] = _array(registry, msg_type, f, v, f"{path}{name}", now_ns)
        else:
            out[name] = _scalar(registry, msg_type, f, v, f"{path}{name}", now_ns)
    return out


_KIND_FLOAT, _KIND_INT, _KIND_OTHER, _KIND_ARRAY, _KIND_STR = range(5)
_MUTABLE = object()
"""A plan's zero for a field whose default is built anew for every message (a list, a
nested message): :func:`_zero` is called then."""
_Plan = tuple[tuple[Field, str, int, int, int, Any], ...]
_PLANS: dict[int, tuple[MessageDef, frozenset[str], _Plan]] = {}


def _plan(definition: MessageDef) -> tuple[frozenset[str], _Plan]:
    """The field names of a definition and, per field, how :func:`from_json` checks it
    (built once per definition: every message goes through it)."""
    cached = _PLANS.get(id(definition))
    if cached is not None and cached[0] is definition:
        return cached[1], cached[2]
    plan: list[tuple[Field, str, int, int, int, Any]] = []
    for f in definition.fields:
        zero = _MUTABLE
        if f.length is None and not f.is_message:
            zero = _zero_scalar_value(f)  # immutable: shared by every message
        lo = hi = 0
        if f.length is not None:
            kind = _KIND_ARRAY
        elif f.is_message:
            kind = _KIND_OTHER
        elif f.type in FLOAT_TYPES:
            kind = _KIND_FLOAT
        elif f.type in INT_RANGES:
            kind = _KIND_INT
            lo, hi = INT_RANGES[f.type]
        elif f.type in ("string", "wstring") and not f.string_bound:
            kind = _KIND_STR  # any str (what _scalar checks for it)
        else:
            kind = _KIND_OTHER
        plan.append((f, f.name, kind, lo, hi, zero))
    names = _field_names(definition)
    _PLANS[id(definition)] = (definition, names, tuple(plan))
    return names, tuple(plan)


_FIELD_NAMES: dict[int, tuple[MessageDef, frozenset[str]]] = {}


def _field_names(definition: MessageDef) -> frozenset[str]:
    """The field names of a definition (built once per definition: every message checks its
    keys against them)."""
    cached = _FIELD_NAMES.get(id(definition))
    if cached is not None and cached[0] is definition:
        return cached[1]
    names = frozenset(f.name for f in definition.fields)
    _FIELD_NAMES[id(definition)] = (definition, names)
    return names


def _time_from_json(msg_type: str, value: Mapping[str, Any], path: str) -> dict[str, Any]:
    sec = value.get("sec")
    nanosec = value.get("nanosec")
    if (  # the common case (what the checks below accept for it), at once
        len(value) == 2
        and type(sec) is int
        and type(nanosec) is int
        and -(2**31) <= sec <= 2**31 - 1
        and 0 <= nanosec <= 2**32 - 1
    ):
        return {"sec": sec, "nanosec": nanosec}
    sec = value.get("sec", value.get("secs", 0))
    nanosec = value.get("nanosec", value.get("nsecs", 0))
    for key in value:
        if key not in ("sec", "nanosec", "secs", "nsecs"):
            raise ConversionError(f"Message type {msg_type} does not have a field {path}{key}")
    for name, v, lo, hi in (("sec", sec, -(2**31), 2**31 - 1), ("nanosec", nanosec, 0, 2**32 - 1)):
        if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
            kind = "an int32" if name == "sec" else "a uint32"
            raise _fail(msg_type, kind, f"{path}{name}", v)
    return {"sec": sec, "nanosec": nanosec}


def _scalar(
    registry: TypeRegistry, msg_type: str, f: Field, v: object, path: str, now_ns: int
) -> Any:
    t = f.type
    if f.is_message:
        return from_json(registry, t, v, now_ns, path + ".")
    if t in INT_RANGES:
        if not isinstance(v, int) or isinstance(v, bool):
            raise _fail(msg_type, f"an int ({t})", path, v)
        lo, hi = INT_RANGES[t]
        if not lo <= v <= hi:
            raise ConversionError(f"{msg_type} field {path} value {v} is out of range for {t}")
        return v
    if t in FLOAT_TYPES:
        if v is None:
            return math.nan
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            raise _fail(msg_type, f"a number ({t})", path, v)
        return float(v)
    if t == "bool":
        if not isinstance(v, bool):
            raise _fail(msg_type, "a bool", path, v)
        return v
    if not isinstance(v, str):
        raise _fail(msg_type, "a string" if t == "string" else f"a string ({t})", path, v)
    if f.string_bound and len(v) > f.string_bound:
        raise ConversionError(f"{msg_type} field {path} is longer than {t}<={f.string_bound}")
    return v


def _array(
    registry: TypeRegistry, msg_type: str, f: Field, v: object, path: str, now_ns: int
) -> Any:
    items: Any
    if f.type in _BYTE_TYPES:
        if isinstance(v, (bytes, bytearray)):
            items = bytes(v)
        elif isinstance(v, str):
            try:
                items = base64.b64decode(v, validate=True)
            except (binascii.Error, ValueError):
                raise _fail(msg_type, "a base64 string or a list of ints", path, v) from None
        elif isinstance(v, list):
            if not all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x < 256 for x in v):
                raise _fail(msg_type, "a base64 string or a list of ints 0..255", path, v)
            items = bytes(v)
        else:
            raise _fail(msg_type, "a base64 string or a list of ints", path, v)
    elif not isinstance(v, list):
        raise _fail(msg_type, f"a list ({f.type}[])", path, v)
    elif (f.type in FLOAT_TYPES and _all_of(v, float)) or (
        f.type == "string" and not f.string_bound and _all_of(v, str)
    ):
        items = list(v)  # the common cases, every element as it must be: nothing to convert
    else:
        scalar = f._replace(length=None, default=None)
        items = [
            _scalar(registry, msg_type, scalar, x, f"{path}[{i}]", now_ns) for i, x in enumerate(v)
        ]
    if f.fixed and len(items) != f.length:
        raise ConversionError(
            f"{msg_type} field {path} needs exactly {f.length} elements, but got {len(items)}"
        )
    if not f.fixed and f.length and len(items) > f.length:
        raise ConversionError(
            f"{msg_type} field {path} allows at most {f.length} elements, but got {len(items)}"
        )
    return items


def _all_of(values: list[Any], kind: type) -> bool:
    """Whether every element is exactly a ``kind`` (a loop: cheaper than ``all()`` over a
    generator for the few elements of a message's array)."""
    for x in values:  # noqa: SIM110
        if type(x) is not kind:
            return False
    return True


# -- JSON out -------------------------------------------------------------------------------


def _json_default(value: object) -> object:
    if isinstance(value, (bytes, bytearray)):
        return base64.b64encode(value).decode("ascii")
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


# One encoder for the whole process: ``json.dumps`` with keyword arguments builds a new
# encoder on every call, which costs about as much as encoding a small message.
_ENCODER = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, default=_json_default
)
# The C encoder ``_ENCODER.encode`` builds for every call, built once: the same text (it is
# what ``encode`` runs), without the per-call set-up. No circular-reference markers: a
# canonical value is a tree (a cycle would fail in ``_finite`` anyway).
_MAKE_ENCODER: Any = getattr(json.encoder, "c_make_encoder", None)
_C_ENCODER: Any = (
    None
    if _MAKE_ENCODER is None
    else _MAKE_ENCODER(
        None, _json_default, json.encoder.encode_basestring, None, ":", ",", False, False, False
    )
)


def dumps(value: Any) -> str:
    """Compact JSON text of a canonical value: bytes as base64, NaN/Inf as null, keys in
    the order they were built (definition order), non-ASCII kept as UTF-8."""
    try:
        if _C_ENCODER is not None:
            return "".join(_C_ENCODER(value, 0))
        return _ENCODER.encode(value)
    except ValueError:
        return _ENCODER.encode(_finite(value))


@functools.lru_cache(maxsize=4096)
def publish_prefix(topic: str) -> str:
    """``{"op":"publish","topic":TOPIC,"msg":`` for a topic as a subscriber spelled it: the
    start of every JSON publish frame to it, built once per topic (the message follows,
    then ``}``)."""
    return '{"op":"publish","topic":' + dumps(topic) + ',"msg":'


# -- CBOR and CDR out -----------------------------------------------------------------------


def _cbor_value(registry: TypeRegistry, msg_type: str, msg: Mapping[str, Any]) -> dict[str, Any]:
    if msg_type in _TIME_TYPES:
        return dict(msg)
    out: dict[str, Any] = {}
    for f in registry.message(msg_type).fields:
        v = msg[f.name]
        if f.length is not None and f.type in _CBOR_TAGS:
            tag, dtype = _CBOR_TAGS[f.type]
            out[f.name] = cbor2.CBORTag(tag, np.asarray(v, dtype=dtype).tobytes())
        elif f.is_message and f.length is not None:
            out[f.name] = [_cbor_value(registry, f.type, x) for x in v]
        elif f.is_message:
            out[f.name] = _cbor_value(registry, f.type, v)
        else:
            out[f.name] = v
    return out


def to_cbor(registry: TypeRegistry, msg_type: str, topic: str, msg: Mapping[str, Any]) -> bytes:
    """The binary ``cbor`` publish frame: numeric arrays as RFC 8746 typed arrays
    (little-endian), ``uint8[]`` as a byte string."""
    frame = {"op": "publish", "topic": topic, "msg": _cbor_value(registry, msg_type, msg)}
    return bytes(cbor2.dumps(frame))


def _rosbags_object(registry: TypeRegistry, msg_type: str, msg: Mapping[str, Any]) -> Any:
    store = registry.store
    cls = store.types[msg_type]
    _, raw_fields = store.fielddefs[msg_type]
    by_name = {f.name: f for f in registry.message(msg_type).fields}
    kwargs: dict[str, Any] = {}
    for fname, _desc in raw_fields:
        f = by_name.get(fname)
        if f is None:  # the member ROS 2 adds to empty structures
            kwargs[fname] = 0
            continue
        v = msg[fname]
        if f.is_message:
            if f.length is None:
                kwargs[fname] = _rosbags_object(registry, f.type, v)
            else:
                kwargs[fname] = [_rosbags_object(registry, f.type, x) for x in v]
        elif f.length is not None and f.type in _NUMPY:
            if isinstance(v, (bytes, bytearray)):
                kwargs[fname] = np.frombuffer(v, dtype=np.uint8).copy()
            else:
                kwargs[fname] = np.asarray(v, dtype=_NUMPY[f.type])
        else:
            kwargs[fname] = v
    return cls(**kwargs)


def to_cdr(registry: TypeRegistry, msg_type: str, msg: Mapping[str, Any]) -> bytes:
    """The CDR bytes (with encapsulation header) of a canonical message, for ``cbor-raw``."""
    obj = _rosbags_object(registry, msg_type, msg)
    return bytes(registry.store.serialize_cdr(obj, msg_type))
