"""CDR of the session's periodic messages from layouts built once (``/joint_states``, ``/tf``,
``/clock``).

The compiled encoder (:func:`harness.recording.cdr.compile_encoder`) walks a message's dict
field by field: about 6 us for a 9-joint ``JointState`` and 25 us for a 9-transform
``TFMessage``, at every publication. Their layout only depends on strings that do not change
during a run (joint names, frame ids), so it is laid out here once, and each message is the
stamp and the numbers packed into it: one ``struct`` call, or the arrays' own bytes. The bytes
are the ones ``rosbags`` gives for the same message (``tests/recording/test_templates.py``
compares them on random values, odd string lengths and empty lists).

Pass the result to :meth:`harness.recording.Recorder.write_message` as the message (bytes are
written as the pre-serialised CDR of the message type).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from harness.recording.cdr import _PAD, CDR_HEADER, _string, _strings

__all__ = ["JointStateCdr", "TfCdr", "clock_cdr"]

_STAMP = struct.Struct("<4siI")  # CDR header, then builtin_interfaces/Time (sec, nanosec)
_F64 = np.dtype(np.float64)


def _stamp(sim_time_ns: int) -> bytes:
    sec, nanosec = divmod(sim_time_ns, 1_000_000_000)
    return _STAMP.pack(CDR_HEADER, sec, nanosec)


def clock_cdr(sim_time_ns: int) -> bytes:
    """``rosgraph_msgs/msg/Clock`` at ``sim_time_ns``."""
    return _stamp(sim_time_ns)


def _f64_prefix(pos: int, count: int) -> tuple[bytes, int]:
    """The bytes before a ``float64[]``'s values at body offset ``pos`` (padding to 4, the
    count, padding to 8 when there are values) and the offset of its values."""
    head = _PAD[: -pos % 4]
    pos += len(head)
    head += struct.pack("<I", count)
    pos += 4
    if count:
        pad = _PAD[: -pos % 8]
        head += pad
        pos += len(pad)
    return head, pos


class JointStateCdr:
    """``sensor_msgs/msg/JointState`` for fixed ``names`` and ``frame_id``: :meth:`encode`
    takes the time and three float64 arrays of ``len(names)`` values each."""

    def __init__(self, names: Sequence[str], frame_id: str = "") -> None:
        self.names = tuple(names)
        n = self.count = len(self.names)
        out: list[bytes] = []
        pos = _string(out, 8, frame_id.encode())  # after the stamp
        pos = _strings(list(self.names), out, pos)
        prefixes = []
        for _ in range(3):
            head, pos = _f64_prefix(pos, n)
            prefixes.append(head)
            pos += 8 * n
        self._middle = b"".join(out) + prefixes[0]
        self._velocity = prefixes[1]
        self._effort = prefixes[2]

    def encode(
        self,
        sim_time_ns: int,
        position: npt.NDArray[np.float64],
        velocity: npt.NDArray[np.float64],
        effort: npt.NDArray[np.float64],
    ) -> bytes:
        """The message's CDR (arrays of ``len(names)`` float64 values; any layout)."""
        n = self.count
        if not (position.size == velocity.size == effort.size == n):
            raise ValueError(
                f"JointState of {n} joints: position, velocity and effort have "
                f"{position.size}, {velocity.size} and {effort.size} values"
            )
        if not (position.dtype is _F64 and velocity.dtype is _F64 and effort.dtype is _F64):
            position, velocity, effort = (
                a.astype(_F64, copy=False) for a in (position, velocity, effort)
            )
        return b"".join(
            (
                _stamp(sim_time_ns),
                self._middle,
                position.tobytes(),
                self._velocity,
                velocity.tobytes(),
                self._effort,
                effort.tobytes(),
            )
        )


class TfCdr:
    """``tf2_msgs/msg/TFMessage`` of fixed ``(frame_id, child_frame_id)`` pairs, every
    transform stamped with the same time: :meth:`encode` takes the time and, per pair, the
    translation ``(x, y, z)`` and the rotation ``(w, x, y, z)`` (MuJoCo's order)."""

    def __init__(self, pairs: Sequence[tuple[str, str]]) -> None:
        self.pairs = tuple(pairs)
        fmt = ["<4sI"]  # CDR header, the number of transforms
        pos = 4
        for parent, child in self.pairs:
            pad = -pos % 4
            fmt.append(f"{pad}xiI")  # header.stamp (the time, repeated)
            pos += pad + 8
            for name in (parent, child):
                raw = name.encode()
                pad = -pos % 4
                fmt.append(f"{pad}xI{len(raw) + 1}s")  # length with its NUL, bytes and NUL
                pos += pad + 4 + len(raw) + 1
            pad = -pos % 8
            fmt.append(f"{pad}x7d")  # translation x y z, rotation x y z w
            pos += pad + 56
        self._struct = struct.Struct("".join(fmt))
        self._strings = [
            (len(p.encode()) + 1, p.encode() + b"\x00", len(c.encode()) + 1, c.encode() + b"\x00")
            for p, c in self.pairs
        ]

    def encode(
        self,
        sim_time_ns: int,
        poses: Sequence[tuple[Sequence[float], Sequence[float]]],
    ) -> bytes:
        """The message's CDR: ``poses[i]`` is ``((x, y, z), (w, x, y, z))`` of pair ``i``."""
        if len(poses) != len(self.pairs):
            raise ValueError(f"TFMessage of {len(self.pairs)} transforms: got {len(poses)} poses")
        sec, nanosec = divmod(sim_time_ns, 1_000_000_000)
        args: list[object] = [CDR_HEADER, len(poses)]
        for (plen, parent, clen, child), ((x, y, z), (w, rx, ry, rz)) in zip(
            self._strings, poses, strict=True
        ):
            args += (sec, nanosec, plen, parent, clen, child, x, y, z, rx, ry, rz, w)
        return self._struct.pack(*args)
