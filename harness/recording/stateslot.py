"""The state slot: a run's per-step :class:`~harness.recording.PhysicsState`, recorded in place.

Building a :class:`PhysicsState` record and laying out its CDR every step costs more than the
state is worth to copy. A slot is bound once to a run's state layout: the caller reads each
state into :attr:`PhysicsStateSlot.state` (``Simulation.get_state(slot.state)``) and calls
:meth:`~PhysicsStateSlot.write`. The :class:`~harness.recording.Recorder`'s slot writes each
state as a complete MCAP message record into a :class:`~harness.recording.writer.RecordRing`
(one ``struct`` call for the record and CDR heads, then the state and ``qpos``/``qvel`` copied
out of it, where ``mjSTATE_INTEGRATION`` keeps them): the bytes
:func:`~harness.recording.cdr.physics_state` and the writer would give, moved into the chunk a
ring at a time. Any other sink gets :class:`PhysicsState` records (:func:`forwarding_slot`).
"""

from __future__ import annotations

import struct
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from harness.recording.errors import RecordingWriteError
from harness.recording.records import PhysicsState
from harness.recording.writer import RecordRing

__all__ = ["HEAD", "PhysicsStateSlot", "StateRecords", "forwarding_slot"]

F64 = npt.NDArray[np.float64]
# the MCAP message record's head (opcode 5, record length, channel id, sequence, log and
# publish time), the CDR header, then step, sim_time_ns, state_spec, len(state)
HEAD = struct.Struct("<BQHIQQ4sQqII")
_RECORD_HEAD = 31  # the MCAP message record's head
_LEN = struct.Struct("<I")


class PhysicsStateSlot:
    """Where a run's state is read each step (:attr:`state`) and how it is recorded
    (:attr:`write`: ``write(step, sim_time_ns)``, the state after ``step``)."""

    __slots__ = ("state", "write")

    def __init__(self, state: F64, write: Callable[[int, int], None]) -> None:
        self.state = state
        self.write = write


def _checked(state_size: int, qpos: slice, qvel: slice) -> tuple[range, range]:
    where = "physics state slot"
    if not isinstance(state_size, int) or state_size < 1:
        raise RecordingWriteError(
            f"{where}: state_size must be an integer >= 1, not {state_size!r}"
        )
    spans = range(state_size)[qpos], range(state_size)[qvel]
    for name, span, part in (("qpos", spans[0], qpos), ("qvel", spans[1], qvel)):
        if span.step != 1 or (part.stop is not None and part.stop > state_size):
            raise RecordingWriteError(
                f"{where}: {name} {part} is not a contiguous part of a state of {state_size} values"
            )
    return spans


def forwarding_slot(
    write_physics_state: Callable[[PhysicsState], None],
    state_spec: int,
    state_size: int,
    qpos: slice,
    qvel: slice,
) -> PhysicsStateSlot:
    """A slot whose writes are :class:`PhysicsState` records passed to
    ``write_physics_state`` (``qpos``/``qvel`` views of the state)."""
    qpos_span, qvel_span = _checked(state_size, qpos, qvel)
    state = np.zeros(state_size, dtype=np.float64)
    q = state[qpos_span.start : qpos_span.stop]
    v = state[qvel_span.start : qvel_span.stop]

    def write(step: int, sim_time_ns: int) -> None:
        write_physics_state(PhysicsState(step, sim_time_ns, state_spec, state, q, v))

    return PhysicsStateSlot(state, write)


class StateRecords:
    """``harness_msgs/msg/PhysicsState`` message records of channel ``channel_id`` laid out
    in ``ring``: :attr:`state` is the array the caller reads each state into. Record ``i`` is
    written by packing :data:`HEAD` at ``i * ring.record_size`` (the record's head, then the
    message's: ``5, 22 + message_size, channel id, sequence, time, time, CDR_HEADER, step,
    time, state_spec, len(state)``) and copying each of :attr:`sources` (the state and the
    ``qpos``/``qvel`` parts of it) into ``targets[i]``'s (the recorder's slot does it inline:
    a call less per step)."""

    __slots__ = ("message_size", "ring", "sources", "state", "targets")

    def __init__(
        self, ring_capacity: int, channel_id: int, state_spec: int, state_size: int,
        qpos: slice, qvel: slice,
    ) -> None:  # fmt: skip
        qpos_span, qvel_span = _checked(state_size, qpos, qvel)
        n, m, k = state_size, len(qpos_span), len(qvel_span)
        # body offsets (after the 4-byte CDR header): head 24, state, then each array's
        # uint32 length and, when it has values, padding to the 8-aligned values
        at_m = 24 + 8 * n
        at_q = at_m + 4 + (-(at_m + 4) % 8 if m else 0)
        at_k = at_q + 8 * m
        at_v = at_k + 4 + (-(at_k + 4) % 8 if k else 0)
        self.message_size = 4 + at_v + 8 * k  # the message's CDR
        record = _RECORD_HEAD + self.message_size
        self.ring = RecordRing(channel_id, record, ring_capacity)
        self.state: F64 = np.zeros(n, dtype=np.float64)
        state = self.state.data.cast("B")
        self.sources = (
            state,
            state[8 * qpos_span.start : 8 * qpos_span.stop],
            state[8 * qvel_span.start : 8 * qvel_span.stop],
        )
        out = memoryview(self.ring.buffer)
        body = _RECORD_HEAD + 4  # the record offset of the CDR body
        dst = []
        for i in range(ring_capacity):
            at = i * record + body
            _LEN.pack_into(out, at + at_m, m)
            _LEN.pack_into(out, at + at_k, k)
            dst.append(
                (
                    out[at + 24 : at + 24 + 8 * n],
                    out[at + at_q : at + at_q + 8 * m],
                    out[at + at_v : at + at_v + 8 * k],
                )
            )
        self.targets = tuple(dst)
