"""Hand-laid CDR encoders for the recorder's per-step messages (the hot path).

``rosbags``' generic ``serialize_cdr`` builds a message object and walks its fields (about
10 us for a ``PhysicsState``); the two messages written every step have a fixed layout, so
they are packed here with one ``struct`` call for the fixed head and the arrays' own bytes.
The bytes are identical to ``rosbags``' (little-endian CDR, the same alignment and padding):
``tests/recording/test_cdr.py`` compares the two on random values, empty arrays and odd
string lengths.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
from rosbags.typesys.store import Typestore

__all__ = [
    "CDR_HEADER",
    "Encoder",
    "Unsupported",
    "bridge_frame",
    "compile_encoder",
    "physics_state",
    "physics_state_parts",
]

CDR_HEADER = b"\x00\x01\x00\x00"
"""The encapsulation header every message starts with (CDR, little-endian)."""
_PAD = b"\x00\x00\x00\x00\x00\x00\x00"
# step, sim_time_ns, state_spec, len(state): offsets 0, 8, 16, 20 -> float64 data at 24
_PS_HEAD = struct.Struct("<QqII")
# step, sim_time_ns, direction, (3 pad), connection, seq: offsets 0, 8, 16, 20, 24 -> 32
_BF_HEAD = struct.Struct("<QqB3xIQ")
_U32 = struct.Struct("<I")
# CDR header, then the PhysicsState head (as _PS_HEAD)
_PS_START = struct.Struct("<4sQqII")
# a float64[] length and the padding to the 8-aligned data after it (non-empty arrays)
_F64_LEN = struct.Struct("<I4x")


def _f64_seq(out: list[bytes], pos: int, array: npt.NDArray[np.float64]) -> int:
    """Append a ``float64[]`` at body offset ``pos`` (a multiple of 4); the new offset."""
    out.append(_U32.pack(array.size))
    pos += 4
    if array.size:
        pad = -pos % 8
        if pad:
            out.append(_PAD[:pad])
            pos += pad
        out.append(array.tobytes())
        pos += 8 * array.size
    return pos


def _string(out: list[bytes], pos: int, text: bytes) -> int:
    """Append a ``string`` (length with its NUL, bytes, NUL) at ``pos``; the new offset."""
    pad = -pos % 4
    if pad:
        out.append(_PAD[:pad])
        pos += pad
    out.append(_U32.pack(len(text) + 1))
    out.append(text)
    out.append(b"\x00")
    return pos + 5 + len(text)


def physics_state(
    step: int,
    sim_time_ns: int,
    state_spec: int,
    state: npt.NDArray[np.float64],
    qpos: npt.NDArray[np.float64],
    qvel: npt.NDArray[np.float64],
) -> bytes:
    """``harness_msgs/msg/PhysicsState`` as CDR (arrays 1-D float64, C-contiguous)."""
    out = [CDR_HEADER, _PS_HEAD.pack(step, sim_time_ns, state_spec, state.size), state.tobytes()]
    pos = 24 + 8 * state.size
    pos = _f64_seq(out, pos, qpos)
    _f64_seq(out, pos, qvel)
    return b"".join(out)


_F64_DTYPE = np.dtype(np.float64)
_STRIDE = (8,)
_LENS: dict[int, bytes] = {}
"""Number of values -> a ``float64[]`` length and the padding after it (few distinct)."""


def _f64_len(count: int) -> bytes:
    packed = _LENS.get(count)
    if packed is None:
        if len(_LENS) >= 256:
            _LENS.clear()
        packed = _LENS[count] = _F64_LEN.pack(count)
    return packed


def physics_state_parts(
    step: int,
    sim_time_ns: int,
    state_spec: int,
    state: npt.NDArray[np.float64],
    qpos: npt.NDArray[np.float64],
    qvel: npt.NDArray[np.float64],
) -> tuple[tuple[bytes | npt.NDArray[np.float64], ...], int] | None:
    """:func:`physics_state` as buffers to write one after the other, and their total size:
    the arrays themselves, not copies of their bytes (the per-step path). ``None`` when an
    array is not a 1-D C-contiguous native float64 array or ``qpos``/``qvel`` is empty (then
    :func:`physics_state` serialises it)."""
    try:
        # ``is``: native float64 is one dtype object; any other spelling takes the slow path.
        if not (
            state.dtype is _F64_DTYPE
            and qpos.dtype is _F64_DTYPE
            and qvel.dtype is _F64_DTYPE
            and state.strides == _STRIDE
            and qpos.strides == _STRIDE
            and qvel.strides == _STRIDE
        ):
            return None
    except AttributeError:
        return None
    n, m, k = state.size, qpos.size, qvel.size
    if not (m and k):
        return None
    head = _PS_START.pack(CDR_HEADER, step, sim_time_ns, state_spec, n)
    return (head, state, _f64_len(m), qpos, _f64_len(k), qvel), 44 + 8 * (n + m + k)


_NAMES: dict[tuple[str, str], tuple[bytes, int]] = {}
"""(op, topic) -> their CDR bytes from offset 32 and the offset after them (few distinct)."""


def _names(op: str, topic: str) -> tuple[bytes, int]:
    out: list[bytes] = []
    pos = _string(out, 32, op.encode())
    pos = _string(out, pos, topic.encode())
    names = (b"".join(out), pos)
    if len(_NAMES) >= 4096:  # many distinct names (a client naming topics freely): start over
        _NAMES.clear()
    _NAMES[(op, topic)] = names
    return names


_TEXT_PREFIXES: dict[tuple[str, str], tuple[bytes, int]] = {}
"""(op, topic) -> the bytes of a text frame from offset 32 up to its text (names, ``binary``
false, padding) and the offset of the text's length."""
_TEXT_TAILS = tuple(b"\x00" + _PAD[:pad] + b"\x00\x00\x00\x00" for pad in range(4))
"""A text's NUL, the padding before ``data``'s length (by its size), that length: 0."""
_BF_START = struct.Struct("<4sQqB3xIQ")  # the CDR header, then _BF_HEAD


def _text_prefix(op: str, topic: str) -> tuple[bytes, int]:
    names, end = _NAMES.get((op, topic)) or _names(op, topic)
    pad = -(end + 1) % 4
    prefix = (names + b"\x00" + _PAD[:pad], end + 1 + pad)
    if len(_TEXT_PREFIXES) >= 4096:
        _TEXT_PREFIXES.clear()
    _TEXT_PREFIXES[(op, topic)] = prefix
    return prefix


def bridge_frame(
    step: int,
    sim_time_ns: int,
    direction: int,
    connection: int,
    seq: int,
    op: str,
    topic: str,
    text: str | None,
    data: bytes | None,
) -> bytes:
    """``harness_msgs/msg/BridgeFrame`` as CDR: exactly one of ``text`` and ``data``."""
    if data is None and text is not None:  # a text frame (most are): one join of five parts
        prefix = _TEXT_PREFIXES.get((op, topic))
        if prefix is None:
            prefix = _text_prefix(op, topic)
        raw = text.encode()
        size = len(raw) + 1
        return b"".join(
            (
                _BF_START.pack(CDR_HEADER, step, sim_time_ns, direction, connection, seq),
                prefix[0],
                _U32.pack(size),
                raw,
                _TEXT_TAILS[-(prefix[1] + 4 + size) % 4],
            )
        )
    names = _NAMES.get((op, topic))
    if names is None:
        names = _names(op, topic)
    out = [CDR_HEADER, _BF_HEAD.pack(step, sim_time_ns, direction, connection, seq), names[0]]
    out.append(b"\x00" if data is None else b"\x01")
    pos = _string(out, names[1] + 1, b"" if text is None else text.encode())
    pad = -pos % 4
    if pad:
        out.append(_PAD[:pad])
    payload = b"" if data is None else bytes(data)
    out.append(_U32.pack(len(payload)))
    out.append(payload)
    return b"".join(out)


class Unsupported(Exception):
    """A value (or a type) the compiled encoder leaves to the generic path: the recorder then
    converts and serialises it with ``rosbags``, which also words any error."""


Encoder = Callable[[Mapping[str, Any]], bytes]
_Field = Callable[[Any, list[bytes], int], int]

_STRUCTS = {
    "bool": (struct.Struct("<?"), 1),
    "int8": (struct.Struct("<b"), 1),
    "uint8": (struct.Struct("<B"), 1),
    "byte": (struct.Struct("<B"), 1),
    "char": (struct.Struct("<B"), 1),
    "int16": (struct.Struct("<h"), 2),
    "uint16": (struct.Struct("<H"), 2),
    "int32": (struct.Struct("<i"), 4),
    "uint32": (struct.Struct("<I"), 4),
    "int64": (struct.Struct("<q"), 8),
    "uint64": (struct.Struct("<Q"), 8),
    "float32": (struct.Struct("<f"), 4),
    "float64": (struct.Struct("<d"), 8),
}
_DTYPES = {
    "int8": "<i1",
    "int16": "<i2",
    "uint16": "<u2",
    "int32": "<i4",
    "uint32": "<u4",
    "int64": "<i8",
    "uint64": "<u8",
    "float32": "<f4",
    "float64": "<f8",
}


def compile_encoder(store: Typestore, msgtype: str) -> Encoder:
    """An encoder from a message in rosbridge JSON form (as
    :func:`harness.recording.convert.from_rosbridge` takes it) to the CDR bytes ``rosbags``
    gives for it. It covers the common forms (numbers, strings, lists, nested objects, missing
    fields); anything else (base64 byte arrays, wrong types or lengths, out-of-range
    integers) raises :class:`Unsupported`, as does compiling a type with bounded fields."""
    body = _message_encoder(store, msgtype)

    def encode(value: Mapping[str, Any]) -> bytes:
        out = [CDR_HEADER]
        try:
            body(value, out, 0)
        except (struct.error, TypeError, ValueError, OverflowError, AttributeError) as exc:
            raise Unsupported(str(exc)) from None
        return b"".join(out)

    return encode


def _align(out: list[bytes], pos: int, size: int) -> int:
    pad = -pos % size
    if pad:
        out.append(_PAD[:pad])
    return pos + pad


def _message_encoder(store: Typestore, msgtype: str) -> _Field:
    if msgtype not in store.fielddefs:
        raise Unsupported(f"unknown type {msgtype}")
    fields = [(name, _field_encoder(store, node)) for name, node in store.fielddefs[msgtype][1]]
    names = frozenset(name for name, _ in fields)

    def encode(value: Any, out: list[bytes], pos: int) -> int:
        if value is None:
            value = {}
        elif type(value) is not dict or not names.issuperset(value):
            raise Unsupported(msgtype)
        get = value.get
        for name, field in fields:
            pos = field(get(name), out, pos)
        return pos

    return encode


def _field_encoder(store: Typestore, node: tuple[Any, Any]) -> _Field:
    kind, arg = int(node[0]), node[1]
    if kind == 1:
        return _base_encoder(*arg)
    if kind == 2:
        return _message_encoder(store, arg)
    (ekind, earg), length = arg
    if kind == 4 and length:
        raise Unsupported("bounded sequence")
    if int(ekind) == 1 and earg[0] in _DTYPES:
        return _numeric_array_encoder(earg[0], length if kind == 3 else None)
    if int(ekind) == 1 and earg[0] != "string":
        raise Unsupported(f"{earg[0]}[]")  # bytes, chars and bools: the generic path
    if kind == 4 and int(ekind) == 1:  # string[] (bounded strings are refused below)
        _base_encoder(*earg)
        return _strings
    element = _field_encoder(store, (ekind, earg))

    def encode(value: Any, out: list[bytes], pos: int) -> int:
        if value is None:
            value = []
        elif type(value) is not list:
            raise Unsupported("list")
        if kind == 3:
            if len(value) != length:
                raise Unsupported("fixed length")
        else:
            pos = _align(out, pos, 4)
            out.append(_U32.pack(len(value)))
            pos += 4
        for item in value:
            pos = element(item, out, pos)
        return pos

    return encode


_STRING_LISTS: dict[tuple[int, tuple[str, ...]], bytes] = {}
"""(offset mod 4, strings) -> their CDR bytes: the joint names of a JointState repeat."""


def _strings(value: Any, out: list[bytes], pos: int) -> int:
    """A ``string[]`` (the names of a JointState): one loop, no call per item; the bytes of a
    list seen before come from :data:`_STRING_LISTS`."""
    if value is None:
        value = []
    elif type(value) is not list:
        raise Unsupported("list")
    key = (pos & 3, tuple(value))
    cached = _STRING_LISTS.get(key)
    if cached is not None:
        out.append(cached)
        return pos + len(cached)
    parts: list[bytes] = []
    pad = -pos % 4
    if pad:
        parts.append(_PAD[:pad])
    parts.append(_U32.pack(len(value)))
    pos += pad + 4
    pack = _U32.pack
    for item in value:
        if type(item) is not str:
            raise Unsupported("string")
        pad = -pos % 4
        if pad:
            parts.append(_PAD[:pad])
        raw = item.encode()
        parts.append(pack(len(raw) + 1))
        parts.append(raw)
        parts.append(b"\x00")
        pos += pad + 5 + len(raw)
    encoded = b"".join(parts)
    if len(_STRING_LISTS) >= 256:  # many distinct lists: start over
        _STRING_LISTS.clear()
    _STRING_LISTS[key] = encoded
    out.append(encoded)
    return pos


_F64_PACKERS: dict[int, struct.Struct] = {}
"""Number of values -> the ``struct`` packing that many float64 (lists of any length)."""


def _f64_packer(n: int) -> struct.Struct:
    packer = _F64_PACKERS.get(n)
    if packer is None:
        if len(_F64_PACKERS) >= 256:
            _F64_PACKERS.clear()
        packer = _F64_PACKERS[n] = struct.Struct(f"<{n}d")
    return packer


def _numeric_array_encoder(basetype: str, length: int | None) -> _Field:
    dtype = np.dtype(_DTYPES[basetype])
    size = dtype.itemsize
    # A list of float64 packs with one struct call (numpy's conversion costs about 1 us a list);
    # anything struct refuses takes the numpy path below, which decides as before.
    packs_lists = basetype == "float64"

    def encode(value: Any, out: list[bytes], pos: int) -> int:
        if value is None:
            value = ()
        elif packs_lists and type(value) is list and (length is None or len(value) == length):
            try:
                raw = _f64_packer(len(value)).pack(*value)
            except (struct.error, TypeError, OverflowError):
                pass
            else:
                if length is None:
                    pos = _align(out, pos, 4)
                    out.append(_U32.pack(len(value)))
                    pos += 4
                if raw:
                    pos = _align(out, pos, 8)
                    out.append(raw)
                    pos += len(raw)
                return pos
        elif type(value) is not list and not isinstance(value, np.ndarray):
            raise Unsupported("list")
        array = np.ascontiguousarray(value, dtype=dtype).reshape(-1)
        if length is None:
            pos = _align(out, pos, 4)
            out.append(_U32.pack(array.size))
            pos += 4
        elif array.size != length:
            if array.size:
                raise Unsupported("fixed length")
            array = np.zeros(length, dtype)  # a missing fixed array is all zeros
        if array.size:
            pos = _align(out, pos, size)
            out.append(array.tobytes())
            pos += size * array.size
        return pos

    return encode


def _base_encoder(basetype: str, bound: int) -> _Field:
    if basetype == "string":
        if bound:
            raise Unsupported("bounded string")

        def string(value: Any, out: list[bytes], pos: int) -> int:
            if value is None:
                value = ""
            elif type(value) is not str:
                raise Unsupported("string")
            return _string(out, pos, value.encode())

        return string
    packer, size = _STRUCTS[basetype]
    pack = packer.pack
    if basetype.startswith("float"):
        kinds: tuple[type, ...] = (float, int)
    elif basetype == "bool":
        kinds = (bool, int)
    else:
        kinds = (int,)

    def number(value: Any, out: list[bytes], pos: int) -> int:
        if value is None:
            value = 0
        elif type(value) not in kinds:
            raise Unsupported(basetype)
        pad = -pos % size
        if pad:
            out.append(_PAD[:pad])
        out.append(pack(value))
        return pos + pad + size

    return number
