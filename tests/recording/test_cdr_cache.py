"""The compiled encoders' shortcuts (string lists seen before, float64 lists packed by struct)
give rosbags' bytes, whatever the alignment and whatever was encoded before."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from harness.recording.cdr import Unsupported, compile_encoder
from harness.recording.convert import from_rosbridge
from harness.recording.layout import typestore


def _rosbags(msgtype: str, value: dict[str, Any]) -> bytes:
    store = typestore()
    return bytes(store.serialize_cdr(from_rosbridge(store, msgtype, value), msgtype))


def test_repeated_and_changed_names_at_every_alignment() -> None:
    encode = compile_encoder(typestore(), "sensor_msgs/msg/JointState")
    for frame_id in ("", "a", "ab", "abc", "abcd"):  # the names start at each offset mod 4
        for names in (["j1", "joint_ä2"], ["j1", "joint_ä2"], ["j1", "joint_b2"], []):
            value = {
                "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": frame_id},
                "name": list(names),
                "position": [0.5] * len(names),
            }
            assert encode(value) == _rosbags("sensor_msgs/msg/JointState", value)


@pytest.mark.parametrize(
    "values",
    [
        [1, 2.5, True, np.float64(-0.0)],  # ints, bools and numpy scalars as numbers
        [float("nan"), float("inf"), 1e308, 2**60],
        [],
    ],
)
def test_float64_lists_as_rosbags(values: list[Any]) -> None:
    value = {"data": values}
    got = compile_encoder(typestore(), "std_msgs/msg/Float64MultiArray")(value)
    assert got == _rosbags("std_msgs/msg/Float64MultiArray", value)


def test_fixed_length_float64_lists() -> None:
    encode = compile_encoder(typestore(), "sensor_msgs/msg/Imu")
    value = {"orientation_covariance": [float(i) for i in range(9)]}
    assert encode(value) == _rosbags("sensor_msgs/msg/Imu", value)
    with pytest.raises(Unsupported):
        encode({"orientation_covariance": [0.0] * 8})  # wrong length: the generic path says so


def test_names_that_are_not_strings_go_to_the_generic_path() -> None:
    encode = compile_encoder(typestore(), "sensor_msgs/msg/JointState")
    with pytest.raises(Unsupported):
        encode({"name": ["a", 3]})
    with pytest.raises(Unsupported):
        encode({"name": [{"x": 1}]})
