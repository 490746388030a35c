"""Typed records read back from a recording (one per ``harness_msgs`` message, plus any message).

Arrays are numpy arrays exactly as recorded (float64 bit for bit); compare them with
:func:`harness.bits.same_bits`, not ``==``. The records that cross the recorder seam every
step (:class:`AppliedInput`, :class:`BridgeFrame`, :class:`PhysicsState`, :class:`Epoch`) are
named tuples: immutable like the frozen dataclasses, and a third of the cost to build (about
0.35 us against 1 us for six fields), which the per-step recording path pays every step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

# One type for one concept: the input the simulation applied is the same record live and read
# back (it mirrors harness_msgs/msg/AppliedInput). It lives in harness.applied, which imports
# only numpy: reading a recording loads neither MuJoCo nor the simulation.
from harness.applied import AppliedInput

__all__ = [
    "AppliedInput",
    "BridgeFrame",
    "CollisionEvent",
    "Epoch",
    "PhysicsState",
    "PhysicsStateArrays",
    "RecordedMessage",
    "RosoutRecord",
]

F64 = npt.NDArray[np.float64]
U32 = npt.NDArray[np.uint32]
I64 = npt.NDArray[np.int64]


@dataclass(frozen=True, slots=True, eq=False)
class RecordedMessage:
    """One message as stored: ``data`` is its CDR bytes; ``msg`` the decoded rosbags object
    (``None`` unless decoding was asked for). ``sim_time_ns`` is the MCAP log time."""

    topic: str
    msgtype: str
    sim_time_ns: int
    sequence: int
    data: bytes
    msg: Any = None


class BridgeFrame(NamedTuple):
    """A rosbridge frame in (``direction`` 0) or out (1), exactly as it crossed the socket."""

    step: int
    sim_time_ns: int
    direction: int
    connection: int
    seq: int
    op: str
    topic: str
    binary: bool = False
    text: str = ""
    data: bytes = b""

    @property
    def payload(self) -> str | bytes:
        """The frame as it was sent: ``data`` for binary frames, ``text`` otherwise."""
        return self.data if self.binary else self.text


class PhysicsState(NamedTuple):
    """The physics state after ``step``: ``state`` is ``mj_getState(..., state_spec)``."""

    step: int
    sim_time_ns: int
    state_spec: int
    state: F64
    qpos: F64
    qvel: F64


class Epoch(NamedTuple):
    """A discontinuity (``reason``, e.g. ``"reset"``) after ``step``: the run continues from
    ``state``, not from the state recorded for ``step`` (which ends the epoch before).
    ``epoch`` counts from 1 within a run."""

    step: int
    sim_time_ns: int
    epoch: int
    reason: str
    state_spec: int
    state: F64
    qpos: F64
    qvel: F64


@dataclass(frozen=True, slots=True, eq=False)
class CollisionEvent:
    """A contact beginning (``kind == 0``), ending (``1``) or a near miss (``2``)."""

    step: int
    sim_time_ns: int
    kind: int
    robot: str
    body1: str
    body2: str
    geom1: str
    geom2: str
    penetration: float
    normal_force: float
    position: tuple[float, float, float]
    normal: tuple[float, float, float]
    duration_ns: int = 0
    distance: float = 0.0
    begin_step: int = 0
    end_step: int = 0


class RosoutRecord(NamedTuple):
    """A ``/rosout`` line as written (levels 10/20/30/40/50, as ``rcl_interfaces/msg/Log``)."""

    sim_time_ns: int
    level: int
    name: str
    msg: str
    file: str = ""
    function: str = ""
    line: int = 0


class PhysicsStateArrays(NamedTuple):
    """Many :class:`PhysicsState` at once, as arrays: row ``i`` of ``state`` (N, nstate),
    ``qpos`` (N, nq) and ``qvel`` (N, nv) is the state after step ``steps[i]``; one
    ``state_spec`` for all (zero rows: an empty recording range)."""

    steps: I64
    sim_time_ns: I64
    state_spec: int
    state: F64
    qpos: F64
    qvel: F64
