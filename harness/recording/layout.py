"""The recording layout: topics, message types, metadata keys, attachments, the typestore.

One MCAP file per run, profile ``ros2``, every channel CDR with a ``ros2msg`` schema and the
channel metadata rosbag2 writes (``offered_qos_profiles``, ``topic_type_hash``). Facts behind
the choices: ``reference/mcap.md`` (a single non-CDR channel makes the file unreadable by
rosbags and ``ros2 bag``).
"""

from __future__ import annotations

from functools import cache
from typing import Final

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from harness.msgs import message_definitions

__all__ = [
    "ATTACHMENT_MODEL",
    "ATTACHMENT_MODEL_BINARY",
    "ATTACHMENT_SCENARIO",
    "ATTACHMENT_SOURCE_PREFIX",
    "FORMAT_VERSION",
    "METADATA_NAME",
    "METADATA_REQUIRED",
    "PROFILE",
    "TOPIC_BRIDGE",
    "TOPIC_CLOCK",
    "TOPIC_COLLISIONS",
    "TOPIC_INPUTS",
    "TOPIC_JOINT_STATES",
    "TOPIC_ROBOT_DESCRIPTION",
    "TOPIC_ROSOUT",
    "TOPIC_STATE",
    "TOPIC_TF",
    "TYPE_APPLIED_INPUT",
    "TYPE_BRIDGE_FRAME",
    "TYPE_COLLISION_EVENT",
    "TYPE_PHYSICS_STATE",
    "channel_metadata",
    "schema_text",
    "typestore",
]

PROFILE: Final = "ros2"
# Bumped when a reader of an older harness could misread a newer file.
FORMAT_VERSION: Final = 1

TOPIC_JOINT_STATES: Final = "/joint_states"
TOPIC_CLOCK: Final = "/clock"
TOPIC_TF: Final = "/tf"
TOPIC_ROBOT_DESCRIPTION: Final = "/robot_description"
TOPIC_ROSOUT: Final = "/rosout"
TOPIC_BRIDGE: Final = "/harness/bridge"
TOPIC_INPUTS: Final = "/harness/inputs"
TOPIC_STATE: Final = "/harness/state"
TOPIC_COLLISIONS: Final = "/harness/collisions"

TYPE_BRIDGE_FRAME: Final = "harness_msgs/msg/BridgeFrame"
TYPE_APPLIED_INPUT: Final = "harness_msgs/msg/AppliedInput"
TYPE_PHYSICS_STATE: Final = "harness_msgs/msg/PhysicsState"
TYPE_COLLISION_EVENT: Final = "harness_msgs/msg/CollisionEvent"

METADATA_NAME: Final = "harness"
# Keys the caller must give (the recorder adds versions, platform and its own settings).
METADATA_REQUIRED: Final = ("timestep", "integrator", "seed", "model_sha256", "control_modes")

ATTACHMENT_MODEL: Final = "model.mjcf.xml"
# The exact compiled model (mj_saveModel): MJCF text keeps only 6 significant digits, so
# bit-exact replay rebuilds from this binary; the MJCF is for people and other tools.
ATTACHMENT_MODEL_BINARY: Final = "model.mjb"
ATTACHMENT_SOURCE_PREFIX: Final = "source/"
ATTACHMENT_SCENARIO: Final = "scenario"


@cache
def typestore() -> Typestore:
    """The ROS 2 Humble typestore with the ``harness_msgs`` types registered (shared, cached)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in message_definitions().items():
        store.register(get_types_from_msg(text, name))
    return store


@cache
def schema_text(msgtype: str) -> bytes:
    """The ``ros2msg`` schema of ``msgtype``: its definition plus its dependencies'."""
    text, _ = typestore().generate_msgdef(msgtype, ros_version=2)
    return text.encode("utf-8")


@cache
def channel_metadata(msgtype: str) -> dict[str, str]:
    """Channel metadata as rosbag2 writes it; empty QoS means defaults (safest for Humble)."""
    return {"offered_qos_profiles": "", "topic_type_hash": typestore().hash_rihs01(msgtype)}
