"""The pre-laid CDR of /joint_states, /tf and /clock gives exactly rosbags' bytes for the same
message (every string length, joint count and time), and a recorder takes it as the message."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.recording import Recorder, Recording
from harness.recording.convert import from_rosbridge
from harness.recording.layout import typestore
from harness.recording.templates import JointStateCdr, TfCdr, clock_cdr

TIMES = st.integers(min_value=0, max_value=2**31 * 1_000_000_000 - 1)
NAMES = st.lists(st.text(min_size=0, max_size=7), max_size=9)
METADATA = {
    "timestep": "0.001",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _rosbags(msgtype: str, msg: dict[str, object]) -> bytes:
    store = typestore()
    return bytes(store.serialize_cdr(from_rosbridge(store, msgtype, msg, where="test"), msgtype))


def _stamp(t: int) -> dict[str, int]:
    return {"sec": t // 1_000_000_000, "nanosec": t % 1_000_000_000}


@settings(max_examples=60, deadline=None)
@given(t=TIMES, names=NAMES, frame=st.text(max_size=5), seed=st.integers(0, 2**32 - 1))
def test_joint_state_matches_rosbags(t: int, names: list[str], frame: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    position, velocity, effort = (rng.standard_normal(len(names)) for _ in range(3))
    msg = {
        "header": {"stamp": _stamp(t), "frame_id": frame},
        "name": names,
        "position": position.tolist(),
        "velocity": velocity.tolist(),
        "effort": effort.tolist(),
    }
    got = JointStateCdr(names, frame).encode(t, position, velocity, effort)
    assert got == _rosbags("sensor_msgs/msg/JointState", msg)


def test_joint_state_takes_strided_and_float32_arrays() -> None:
    qpos = np.arange(12, dtype=np.float64)
    template = JointStateCdr(["a", "b", "c"])
    strided = template.encode(5, qpos[::4], qpos[1:4].astype(np.float32), qpos[:3])
    plain = template.encode(5, np.array([0.0, 4.0, 8.0]), np.array([1.0, 2.0, 3.0]), qpos[:3])
    assert strided == plain


def test_joint_state_refuses_a_wrong_count() -> None:
    with pytest.raises(ValueError, match="JointState of 2 joints: position, velocity and effort"):
        JointStateCdr(["a", "b"]).encode(0, np.zeros(2), np.zeros(3), np.zeros(2))


@settings(max_examples=60, deadline=None)
@given(
    t=TIMES,
    pairs=st.lists(st.tuples(st.text(max_size=6), st.text(max_size=6)), max_size=6),
    seed=st.integers(0, 2**32 - 1),
)
def test_tf_matches_rosbags(t: int, pairs: list[tuple[str, str]], seed: int) -> None:
    rng = np.random.default_rng(seed)
    poses = [(tuple(rng.standard_normal(3)), tuple(rng.standard_normal(4))) for _ in pairs]
    msg = {
        "transforms": [
            {
                "header": {"stamp": _stamp(t), "frame_id": parent},
                "child_frame_id": child,
                "transform": {
                    "translation": {"x": xyz[0], "y": xyz[1], "z": xyz[2]},
                    "rotation": {"x": q[1], "y": q[2], "z": q[3], "w": q[0]},
                },
            }
            for (parent, child), (xyz, q) in zip(pairs, poses, strict=True)
        ]
    }
    assert TfCdr(pairs).encode(t, poses) == _rosbags("tf2_msgs/msg/TFMessage", msg)


def test_tf_refuses_a_wrong_count() -> None:
    with pytest.raises(ValueError, match="TFMessage of 1 transforms: got 0 poses"):
        TfCdr([("world", "base")]).encode(0, [])


@settings(max_examples=30, deadline=None)
@given(t=TIMES)
def test_clock_matches_rosbags(t: int) -> None:
    assert clock_cdr(t) == _rosbags("rosgraph_msgs/msg/Clock", {"clock": _stamp(t)})


def test_recorder_writes_pre_serialised_cdr_as_the_message(tmp_path: Path) -> None:
    """Bytes given to write_message are that message's CDR: the same file as the dict gives."""
    template = JointStateCdr(["j1", "j2"])
    position, velocity, effort = np.array([0.5, -1.0]), np.array([0.0, 2.0]), np.zeros(2)
    msg = {
        "header": {"stamp": _stamp(3_000_000), "frame_id": ""},
        "name": ["j1", "j2"],
        "position": position.tolist(),
        "velocity": velocity.tolist(),
        "effort": effort.tolist(),
    }
    files = []
    for name, payload in [
        ("dict", msg),
        ("cdr", template.encode(3_000_000, position, velocity, effort)),
    ]:
        path = tmp_path / f"{name}.mcap"
        with Recorder(path, metadata=METADATA, library="test") as rec:
            rec.write_message("/joint_states", "sensor_msgs/msg/JointState", payload,
                              sim_time_ns=3_000_000)  # fmt: skip
            rec.write_message("/clock", "rosgraph_msgs/msg/Clock", clock_cdr(3_000_000),
                              sim_time_ns=3_000_000)  # fmt: skip
        files.append(path)
    with Recording(files[1]) as recording:
        (read,) = list(recording.messages("/joint_states", decode=True))
        assert list(read.msg.position) == [0.5, -1.0]
        assert list(read.msg.name) == ["j1", "j2"]
    with Recording(files[0]) as a, Recording(files[1]) as b:
        assert [m.data for m in a.messages()] == [m.data for m in b.messages()]


def test_recorder_refuses_bytes_that_are_not_cdr(tmp_path: Path) -> None:
    """Bytes without the CDR header are refused with one line naming the topic; the file is
    still complete and holds what came before."""
    from harness.recording import RecordingWriteError

    path = tmp_path / "bad.mcap"
    with Recorder(path, metadata=METADATA, library="test") as rec:
        rec.write_message("/clock", "rosgraph_msgs/msg/Clock", clock_cdr(1), sim_time_ns=1)
        with pytest.raises(RecordingWriteError, match=r"^/clock \(rosgraph_msgs/msg/Clock\): pre"):
            rec.write_message("/clock", "rosgraph_msgs/msg/Clock", b"{}", sim_time_ns=2)
    with Recording(path) as recording:
        assert [m.sim_time_ns for m in recording.messages("/clock")] == [1]
