"""The messages the simulated robot publishes, as rosbridge JSON dicts, stamped in sim time."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "TYPE_CLOCK",
    "TYPE_FORWARD",
    "TYPE_JOINT_STATE",
    "TYPE_LOG",
    "TYPE_STRING",
    "TYPE_TF",
    "TYPE_TRAJECTORY",
    "clock_msg",
    "joint_state_msg",
    "log_msg",
    "period_steps",
    "stamp",
    "tf_msg",
]

F64 = npt.NDArray[np.float64]

TYPE_JOINT_STATE = "sensor_msgs/msg/JointState"
TYPE_CLOCK = "rosgraph_msgs/msg/Clock"
TYPE_TF = "tf2_msgs/msg/TFMessage"
TYPE_STRING = "std_msgs/msg/String"
TYPE_LOG = "rcl_interfaces/msg/Log"
TYPE_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
TYPE_FORWARD = "std_msgs/msg/Float64MultiArray"


def stamp(sim_time_ns: int) -> dict[str, int]:
    """``builtin_interfaces/Time`` of a simulation time."""
    sec, nanosec = divmod(sim_time_ns, 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def period_steps(rate_hz: float | None, dt_ns: int) -> int:
    """Steps between publications at ``rate_hz`` of simulation time (0: never). A rate above
    the step rate publishes every step."""
    if not rate_hz:
        return 0
    return max(1, round(1e9 / rate_hz / dt_ns))


def joint_state_msg(
    sim_time_ns: int,
    names: Sequence[str],
    position: F64,
    velocity: F64,
    effort: F64,
    frame_id: str = "",
) -> dict[str, Any]:
    """A ``sensor_msgs/msg/JointState``."""
    return {
        "header": {"stamp": stamp(sim_time_ns), "frame_id": frame_id},
        "name": list(names),
        "position": position.tolist(),
        "velocity": velocity.tolist(),
        "effort": effort.tolist(),
    }


def clock_msg(sim_time_ns: int) -> dict[str, Any]:
    """A ``rosgraph_msgs/msg/Clock``."""
    return {"clock": stamp(sim_time_ns)}


def tf_msg(
    sim_time_ns: int, poses: Mapping[str, tuple[F64, F64]], parent: str, prefix: str = ""
) -> dict[str, Any]:
    """A ``tf2_msgs/msg/TFMessage``: each ``child -> (xyz, quat w-x-y-z)`` in ``parent``'s
    frame; child frame ids get ``prefix``."""
    header = {"stamp": stamp(sim_time_ns), "frame_id": parent}
    transforms = []
    for child, (xyz, quat) in poses.items():
        x, y, z = xyz.tolist()
        w, qx, qy, qz = quat.tolist()
        transforms.append(
            {
                "header": header,
                "child_frame_id": prefix + child,
                "transform": {
                    "translation": {"x": x, "y": y, "z": z},
                    "rotation": {"x": qx, "y": qy, "z": qz, "w": w},
                },
            }
        )
    return {"transforms": transforms}


def log_msg(sim_time_ns: int, level: int, name: str, text: str) -> dict[str, Any]:
    """A ``rcl_interfaces/msg/Log`` (levels 10/20/30/40/50)."""
    return {
        "stamp": stamp(sim_time_ns),
        "level": level,
        "name": name,
        "msg": text,
        "file": "",
        "function": "",
        "line": 0,
    }
