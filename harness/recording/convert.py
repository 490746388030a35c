"""Messages in rosbridge JSON form (plain dicts) to rosbags message objects, and back.

rosbridge encodes ``uint8[]``/``char[]`` arrays as base64 strings and times as
``{"sec", "nanosec"}``; missing fields take their default value, unknown fields are an error
naming the key path.
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from rosbags.typesys.store import Typestore

from harness.recording.errors import RecordingWriteError

__all__ = ["from_rosbridge", "to_plain"]

# rosbags field-node kinds (rosbags.interfaces.Nodetype values).
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4

_NUMPY: dict[str, type[np.generic]] = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}
_BYTES = {"uint8", "char", "byte"}


def from_rosbridge(store: Typestore, msgtype: str, value: Any, *, where: str = "") -> Any:
    """Build a rosbags ``msgtype`` object from its rosbridge JSON form ``value``."""
    if msgtype not in store.fielddefs:
        raise RecordingWriteError(f"unknown message type {msgtype!r}")
    return _message(store, msgtype, value, where or msgtype)


def _message(store: Typestore, msgtype: str, value: Any, where: str) -> Any:
    if not isinstance(value, Mapping):
        raise RecordingWriteError(
            f"{where}: expected an object for {msgtype}, got {type(value).__name__}"
        )
    _, fields = store.fielddefs[msgtype]
    names = {name for name, _ in fields}
    unknown = sorted(set(value) - names)
    if unknown:
        raise RecordingWriteError(f"{where}: unknown field {unknown[0]!r} for {msgtype}")
    kwargs = {
        name: _field(store, node, value.get(name), f"{where}.{name}") for name, node in fields
    }
    return store.types[msgtype](**kwargs)


def _field(store: Typestore, node: tuple[Any, Any], value: Any, where: str) -> Any:
    kind, arg = node
    kind = int(kind)
    if kind == _BASE:
        return _base(arg[0], value, where)
    if kind == _NAME:
        return _message(store, arg, {} if value is None else value, where)
    element, length = arg
    ekind, earg = int(element[0]), element[1]
    if ekind == _BASE and earg[0] != "string":
        array = _numeric_array(earg[0], value, where)
        if kind == _ARRAY and array.shape[0] != length:
            array = _fixed(array, length, where)
        return array
    items = [] if value is None else value
    if not isinstance(items, Sequence) or isinstance(items, str | bytes):
        raise RecordingWriteError(f"{where}: expected a list, got {type(items).__name__}")
    out = [_field(store, element, item, f"{where}[{i}]") for i, item in enumerate(items)]
    if kind == _ARRAY and len(out) != length:
        if out:
            raise RecordingWriteError(f"{where}: expected {length} items, got {len(out)}")
        out = [_field(store, element, None, f"{where}[{i}]") for i in range(length)]
    return out


def _fixed(array: np.ndarray[Any, Any], length: int, where: str) -> np.ndarray[Any, Any]:
    if array.shape[0] == 0:
        return np.zeros(length, dtype=array.dtype)
    raise RecordingWriteError(f"{where}: expected {length} items, got {array.shape[0]}")


def _numeric_array(basetype: str, value: Any, where: str) -> np.ndarray[Any, Any]:
    dtype = _NUMPY[basetype]
    if value is None:
        return np.zeros(0, dtype=dtype)
    if basetype in _BYTES and isinstance(value, str):
        try:
            raw = base64.b64decode(value, validate=True)
        except (binascii.Error, ValueError):
            raise RecordingWriteError(f"{where}: invalid base64 for {basetype}[]") from None
        out: np.ndarray[Any, Any] = np.frombuffer(raw, dtype=np.uint8).copy()
        return out
    if isinstance(value, bytes | bytearray | memoryview) and basetype in _BYTES:
        out = np.frombuffer(bytes(value), dtype=np.uint8).copy()
        return out
    try:
        array: np.ndarray[Any, Any] = np.ascontiguousarray(value, dtype=dtype).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise RecordingWriteError(f"{where}: expected a list of {basetype}") from None
    return array


def _base(basetype: str, value: Any, where: str) -> Any:
    if basetype == "string":
        if value is None:
            return ""
        if not isinstance(value, str):
            raise RecordingWriteError(f"{where}: expected a string, got {type(value).__name__}")
        return value
    if basetype == "bool":
        if value is None:
            return False
        if not isinstance(value, bool | int):
            raise RecordingWriteError(f"{where}: expected a bool, got {type(value).__name__}")
        return bool(value)
    if value is None:
        return 0.0 if basetype.startswith("float") else 0
    if basetype.startswith("float"):
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise RecordingWriteError(f"{where}: expected a number, got {type(value).__name__}")
        return float(value)
    if not isinstance(value, int) or isinstance(value, bool):
        raise RecordingWriteError(f"{where}: expected an integer, got {type(value).__name__}")
    info = np.iinfo(_NUMPY[basetype])  # type: ignore[type-var]
    if not info.min <= value <= info.max:
        raise RecordingWriteError(f"{where}: {value} out of range for {basetype}")
    return value


def to_plain(msg: Any) -> Any:
    """A rosbags message object as plain Python data (dicts, lists, numbers, strings)."""
    if dataclasses.is_dataclass(msg) and not isinstance(msg, type):
        # ROS 2 field names are lower case and constants upper case; rosbags keeps both.
        return {
            f.name: to_plain(getattr(msg, f.name))
            for f in dataclasses.fields(msg)
            if f.name != "__msgtype__" and not f.name.isupper()
        }
    if isinstance(msg, np.ndarray):
        return msg.tolist()
    if isinstance(msg, list | tuple):
        return [to_plain(item) for item in msg]
    if isinstance(msg, np.generic):
        return msg.item()
    return msg
