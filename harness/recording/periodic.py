"""The session's periodic messages as records (``/joint_states``, ``/tf``, ``/clock``).

The session core hands these to :meth:`harness.recording.Recorder.write_message` as the
message, as it hands :class:`BridgeFrame`\\ s and :class:`Epoch`\\ s to their own methods: the
numbers of one publication and the strings that name them, no encoding. The recorder writes
each as its CDR, laid out once per set of names (:mod:`harness.recording.templates`), so the
session knows nothing of the file format and the bytes are those of the message's dict form
(``tests/session/test_recorded_topics.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from harness.recording.templates import JointStateCdr, TfCdr, clock_cdr

__all__ = ["PERIODIC_RECORDS", "ClockRecord", "JointStateRecord", "TfRecord"]

F64 = npt.NDArray[np.float64]
_LAYOUTS_MAX = 256  # distinct name sets kept laid out (a process running many robots)
_joint_layouts: dict[tuple[tuple[str, ...], str], JointStateCdr] = {}
_tf_layouts: dict[tuple[tuple[str, str], ...], TfCdr] = {}


class JointStateRecord(NamedTuple):
    """One ``sensor_msgs/msg/JointState``: ``position``, ``velocity`` and ``effort`` hold
    ``len(names)`` values each (float64 arrays, any layout)."""

    sim_time_ns: int
    names: tuple[str, ...]
    position: F64
    velocity: F64
    effort: F64
    frame_id: str = ""

    def cdr(self) -> bytes:
        """The message's CDR."""
        key = (self.names, self.frame_id)
        layout = _joint_layouts.get(key)
        if layout is None:
            if len(_joint_layouts) >= _LAYOUTS_MAX:
                _joint_layouts.clear()
            layout = _joint_layouts[key] = JointStateCdr(self.names, self.frame_id)
        return layout.encode(self.sim_time_ns, self.position, self.velocity, self.effort)


class TfRecord(NamedTuple):
    """One ``tf2_msgs/msg/TFMessage`` of the ``(frame_id, child_frame_id)`` ``pairs``, every
    transform stamped ``sim_time_ns``: ``poses[i]`` is ``((x, y, z), (w, x, y, z))`` of pair
    ``i`` (MuJoCo's quaternion order)."""

    sim_time_ns: int
    pairs: tuple[tuple[str, str], ...]
    poses: Sequence[tuple[Sequence[float], Sequence[float]]]

    def cdr(self) -> bytes:
        """The message's CDR."""
        layout = _tf_layouts.get(self.pairs)
        if layout is None:
            if len(_tf_layouts) >= _LAYOUTS_MAX:
                _tf_layouts.clear()
            layout = _tf_layouts[self.pairs] = TfCdr(self.pairs)
        return layout.encode(self.sim_time_ns, self.poses)


class ClockRecord(NamedTuple):
    """One ``rosgraph_msgs/msg/Clock`` at ``sim_time_ns``."""

    sim_time_ns: int

    def cdr(self) -> bytes:
        """The message's CDR."""
        return clock_cdr(self.sim_time_ns)


PERIODIC_RECORDS = (JointStateRecord, TfRecord, ClockRecord)
"""The record types :meth:`~harness.recording.Recorder.write_message` takes as a message."""
