"""Compiled rosbridge-dict encoders give rosbags' bytes, or leave the value to the generic path."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from harness.recording.cdr import Unsupported, compile_encoder
from harness.recording.convert import from_rosbridge
from harness.recording.errors import RecordingWriteError
from harness.recording.layout import typestore

STAMP = {"sec": 12, "nanosec": 345}
CASES: list[tuple[str, dict[str, Any]]] = [
    ("rosgraph_msgs/msg/Clock", {"clock": STAMP}),
    ("rosgraph_msgs/msg/Clock", {}),
    (
        "sensor_msgs/msg/JointState",
        {
            "header": {"stamp": STAMP, "frame_id": ""},
            "name": ["j1", "joint_ä2", "j3"],
            "position": [0.5, -1.0, 2],
            "velocity": [],
            "effort": [1.0, 2.0, 3.0],
        },
    ),
    ("sensor_msgs/msg/JointState", {"name": ["a"], "position": np.arange(1.0, 2.0)}),
    (
        "tf2_msgs/msg/TFMessage",
        {
            "transforms": [
                {
                    "header": {"stamp": STAMP, "frame_id": "world"},
                    "child_frame_id": f"link{i}",
                    "transform": {
                        "translation": {"x": 1.0, "y": 2.0, "z": i},
                        "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
                    },
                }
                for i in range(3)
            ]
        },
    ),
    (
        "rcl_interfaces/msg/Log",
        {"stamp": STAMP, "level": 20, "name": "n", "msg": "hello", "file": "f.py", "line": 7},
    ),
    ("sensor_msgs/msg/Imu", {"orientation": {"w": 1.0}, "angular_velocity_covariance": [0.0] * 9}),
    ("std_msgs/msg/Bool", {"data": True}),
    ("std_msgs/msg/Int8", {"data": -3}),
    (
        "std_msgs/msg/Float32MultiArray",
        {"layout": {"dim": [{"label": "x", "size": 2, "stride": 2}]}, "data": [1.5, 2.5]},
    ),
    ("std_msgs/msg/Empty", {}),
]


@pytest.mark.parametrize(("msgtype", "value"), CASES)
def test_same_bytes_as_rosbags(msgtype: str, value: dict[str, Any]) -> None:
    store = typestore()
    expected = store.serialize_cdr(from_rosbridge(store, msgtype, value), msgtype)
    assert compile_encoder(store, msgtype)(value) == bytes(expected)


@pytest.mark.parametrize(
    ("msgtype", "value"),
    [
        ("std_msgs/msg/Int8", {"data": 300}),  # out of range
        ("std_msgs/msg/Int32", {"data": True}),  # a bool is not an integer
        ("std_msgs/msg/Int32", {"data": 1.5}),
        ("std_msgs/msg/String", {"data": 3}),
        ("std_msgs/msg/String", {"data": "x", "extra": 1}),  # unknown field
        ("sensor_msgs/msg/JointState", {"position": ["a"]}),
        ("sensor_msgs/msg/Imu", {"angular_velocity_covariance": [0.0] * 8}),
        ("std_msgs/msg/String", {"data": "\ud800"}),  # not encodable as UTF-8
    ],
)
def test_bad_values_go_to_the_generic_path(msgtype: str, value: dict[str, Any]) -> None:
    store = typestore()
    with pytest.raises(Unsupported):
        compile_encoder(store, msgtype)(value)


def test_byte_arrays_and_unknown_types_are_not_compiled() -> None:
    store = typestore()
    with pytest.raises(Unsupported):
        compile_encoder(store, "sensor_msgs/msg/Image")  # uint8[] data: base64 in rosbridge
    with pytest.raises(Unsupported):
        compile_encoder(store, "no_such/msg/Type")


def test_recorder_words_errors_of_compiled_types(tmp_path: Any) -> None:
    from harness.recording import Recorder, Recording

    metadata = {"timestep": "0.001", "integrator": "implicitfast", "seed": "0",
                "model_sha256": "0" * 64, "control_modes": "{}"}  # fmt: skip
    with Recorder(tmp_path / "r.mcap", metadata=metadata) as rec:
        rec.write_message("/c", "rosgraph_msgs/msg/Clock", {"clock": STAMP}, sim_time_ns=1)
        with pytest.raises(RecordingWriteError, match=r"/n \(std_msgs/msg/Int8\).*out of range"):
            rec.write_message("/n", "std_msgs/msg/Int8", {"data": 300}, sim_time_ns=2)
        rec.write_message("/n", "std_msgs/msg/Int8", {"data": -3}, sim_time_ns=2)
    messages = list(Recording(tmp_path / "r.mcap").messages(topics=["/c", "/n"]))
    assert [m.topic for m in messages] == ["/c", "/n"]
