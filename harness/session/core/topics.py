"""The topics the simulated robot publishes (:class:`TopicDef`: type, publishing node,
latched or not) and their messages, as rosbridge JSON dicts, stamped in sim time."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

__all__ = [
    "HARNESS_NODE",
    "JOINT_STATE_BROADCASTER",
    "ROBOT_STATE_PUBLISHER",
    "TYPE_CLOCK",
    "TYPE_FORWARD",
    "TYPE_JOINT_STATE",
    "TYPE_LOG",
    "TYPE_STRING",
    "TYPE_TF",
    "TYPE_TRAJECTORY",
    "TopicDef",
    "clock_msg",
    "joint_state_msg",
    "log_msg",
    "node_name",
    "period_steps",
    "robot_topic_defs",
    "stamp",
]

F64 = npt.NDArray[np.float64]

TYPE_JOINT_STATE = "sensor_msgs/msg/JointState"
TYPE_CLOCK = "rosgraph_msgs/msg/Clock"
TYPE_TF = "tf2_msgs/msg/TFMessage"
TYPE_STRING = "std_msgs/msg/String"
TYPE_LOG = "rcl_interfaces/msg/Log"
TYPE_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
TYPE_FORWARD = "std_msgs/msg/Float64MultiArray"

HARNESS_NODE: Final = "/harness"
"""The session's own node (``/clock``, ``/rosout``, the ``/harness/*`` services)."""
ROBOT_STATE_PUBLISHER: Final = "robot_state_publisher"
"""The node of a robot's ``tf``, ``tf_static`` and ``robot_description`` (in its namespace)."""
JOINT_STATE_BROADCASTER: Final = "joint_state_broadcaster"
"""The node of a robot's ``joint_states`` (in its namespace)."""


@dataclass(frozen=True)
class TopicDef:
    """A topic the simulation publishes: resolved ``name``, ``type``, the ROS ``node`` that
    publishes it (absolute), and ``latched``: transient-local durability (the last message
    reaches late subscribers; offer it so in a recording's QoS profile)."""

    name: str
    type: str
    node: str
    latched: bool = False


def node_name(namespace: str, node: str) -> str:
    """The absolute name of ``node`` in ``namespace`` (``/ns/node`` or ``/node``)."""
    return f"/{namespace.strip('/')}/{node}" if namespace.strip("/") else f"/{node}"


def robot_topic_defs(
    namespace: str,
    *,
    joint_states: str | None,
    tf: str | None,
    tf_static: str,
    robot_description: str,
) -> tuple[TopicDef, ...]:
    """The topics one robot publishes, under the nodes a real ROS 2 robot shows (a topic
    given as None is turned off)."""
    rsp = node_name(namespace, ROBOT_STATE_PUBLISHER)
    defs = [
        TopicDef(tf_static, TYPE_TF, rsp, latched=True),
        TopicDef(robot_description, TYPE_STRING, rsp, latched=True),
    ]
    if tf is not None:
        defs.append(TopicDef(tf, TYPE_TF, rsp))
    if joint_states is not None:
        defs.append(
            TopicDef(joint_states, TYPE_JOINT_STATE, node_name(namespace, JOINT_STATE_BROADCASTER))
        )
    return tuple(defs)


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
