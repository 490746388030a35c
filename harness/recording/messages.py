"""The rosbags messages of the records the recorder serialises with the generic encoder (inputs,
epochs, collision events, ``/rosout``), checked: a bad field is a one-line
:class:`~harness.recording.RecordingWriteError` naming the topic and step."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from harness.recording.errors import RecordingWriteError
from harness.recording.layout import (
    TOPIC_COLLISIONS,
    TOPIC_EPOCH,
    TOPIC_INPUTS,
    TYPE_APPLIED_INPUT,
    TYPE_COLLISION_EVENT,
    TYPE_EPOCH,
)
from harness.recording.records import AppliedInput, CollisionEvent, Epoch, RosoutRecord

__all__ = [
    "applied_input_message",
    "collision_event_message",
    "epoch_message",
    "f64",
    "rosout_message",
    "u32",
]


def f64(value: Sequence[float] | npt.ArrayLike, where: str) -> npt.NDArray[np.float64]:
    """``value`` as a 1-D C-contiguous float64 array (``where`` names it in the error)."""
    try:
        # serialize_cdr needs C-contiguous arrays (model slices and reversed views are not).
        array = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise RecordingWriteError(f"{where}: expected a sequence of numbers") from None
    return array.reshape(-1) if array.ndim != 1 else array


def u32(value: Sequence[int] | npt.ArrayLike, where: str) -> npt.NDArray[np.uint32]:
    """``value`` as a 1-D uint32 array of non-negative integers."""
    try:
        array = np.asarray(value)
        if array.size and (array.dtype.kind not in "iu" or array.min() < 0):
            raise ValueError
        return np.ascontiguousarray(array, dtype=np.uint32).reshape(-1)
    except (TypeError, ValueError):
        raise RecordingWriteError(f"{where}: expected non-negative integers") from None


def applied_input_message(types: Mapping[str, Any], inp: AppliedInput) -> Any:
    """The ``harness_msgs/msg/AppliedInput`` of ``inp`` (checked)."""
    step = inp.step
    where = f"{TOPIC_INPUTS} step {step}"
    qpos_i = u32(inp.qpos_index, f"{where}: qpos_index")
    qpos_v = f64(inp.qpos_value, f"{where}: qpos_value")
    qvel_i = u32(inp.qvel_index, f"{where}: qvel_index")
    qvel_v = f64(inp.qvel_value, f"{where}: qvel_value")
    if qpos_i.shape != qpos_v.shape or qvel_i.shape != qvel_v.shape:
        raise RecordingWriteError(f"{where}: index and value arrays differ in length")
    return types[TYPE_APPLIED_INPUT](
        step=step,
        sim_time_ns=inp.sim_time_ns,
        ctrl=f64(inp.ctrl, f"{where}: ctrl"),
        kinematic_joints=list(inp.kinematic_joints),
        qpos_index=qpos_i,
        qpos_value=qpos_v,
        qvel_index=qvel_i,
        qvel_value=qvel_v,
        mocap_pos=f64(inp.mocap_pos, f"{where}: mocap_pos"),
        mocap_quat=f64(inp.mocap_quat, f"{where}: mocap_quat"),
        qfrc_applied=f64(inp.qfrc_applied, f"{where}: qfrc_applied"),
        xfrc_applied=f64(inp.xfrc_applied, f"{where}: xfrc_applied"),
    )


def epoch_message(types: Mapping[str, Any], epoch: Epoch) -> Any:
    """The ``harness_msgs/msg/Epoch`` of ``epoch`` (checked)."""
    where = f"{TOPIC_EPOCH} step {epoch.step}"
    return types[TYPE_EPOCH](
        step=epoch.step,
        sim_time_ns=epoch.sim_time_ns,
        epoch=epoch.epoch,
        reason=epoch.reason,
        state_spec=epoch.state_spec,
        state=f64(epoch.state, f"{where}: state"),
        qpos=f64(epoch.qpos, f"{where}: qpos"),
        qvel=f64(epoch.qvel, f"{where}: qvel"),
    )


def collision_event_message(types: Mapping[str, Any], record: CollisionEvent) -> Any:
    """The ``harness_msgs/msg/CollisionEvent`` of ``record`` (checked)."""
    position, normal = record.position, record.normal
    if len(position) != 3 or len(normal) != 3:
        raise RecordingWriteError(
            f"{TOPIC_COLLISIONS} step {record.step}: position and normal need 3 components"
        )
    point = types["geometry_msgs/msg/Point"]
    vector = types["geometry_msgs/msg/Vector3"]
    return types[TYPE_COLLISION_EVENT](
        step=record.step,
        sim_time_ns=record.sim_time_ns,
        kind=record.kind,
        robot=record.robot,
        body1=record.body1,
        body2=record.body2,
        geom1=record.geom1,
        geom2=record.geom2,
        penetration=float(record.penetration),
        normal_force=float(record.normal_force),
        position=point(x=float(position[0]), y=float(position[1]), z=float(position[2])),
        normal=vector(x=float(normal[0]), y=float(normal[1]), z=float(normal[2])),
        duration_ns=record.duration_ns,
        distance=float(record.distance),
        begin_step=record.begin_step,
        end_step=record.end_step,
    )


def rosout_message(types: Mapping[str, Any], record: RosoutRecord) -> Any:
    """The ``rcl_interfaces/msg/Log`` of ``record``."""
    sec, nanosec = divmod(record.sim_time_ns, 1_000_000_000)
    return types["rcl_interfaces/msg/Log"](
        stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
        level=record.level,
        name=record.name,
        msg=record.msg,
        file=record.file,
        function=record.function,
        line=record.line,
    )
