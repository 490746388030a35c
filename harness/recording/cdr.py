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

import numpy as np
import numpy.typing as npt

__all__ = ["bridge_frame", "physics_state"]

_HEADER = b"\x00\x01\x00\x00"  # CDR little-endian encapsulation
_PAD = b"\x00\x00\x00\x00\x00\x00\x00"
# step, sim_time_ns, state_spec, len(state): offsets 0, 8, 16, 20 -> float64 data at 24
_PS_HEAD = struct.Struct("<QqII")
# step, sim_time_ns, direction, (3 pad), connection, seq: offsets 0, 8, 16, 20, 24 -> 32
_BF_HEAD = struct.Struct("<QqB3xIQ")
_U32 = struct.Struct("<I")


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
    out = [_HEADER, _PS_HEAD.pack(step, sim_time_ns, state_spec, state.size), state.tobytes()]
    pos = 24 + 8 * state.size
    pos = _f64_seq(out, pos, qpos)
    _f64_seq(out, pos, qvel)
    return b"".join(out)


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
    out = [_HEADER, _BF_HEAD.pack(step, sim_time_ns, direction, connection, seq)]
    pos = _string(out, 32, op.encode())
    pos = _string(out, pos, topic.encode())
    out.append(b"\x00" if data is None else b"\x01")
    pos = _string(out, pos + 1, b"" if text is None else text.encode())
    pad = -pos % 4
    if pad:
        out.append(_PAD[:pad])
    payload = b"" if data is None else bytes(data)
    out.append(_U32.pack(len(payload)))
    out.append(payload)
    return b"".join(out)
