"""Every write_* call reads back equal, floats bit for bit; bad arguments get clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from harness.errors import RecordingError
from harness.recording import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    PhysicsState,
    Recorder,
    Recording,
    RecordingWriteError,
    RosoutRecord,
)
from harness.recording.layout import typestore

METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "3",
    "model_sha256": "ab" * 32,
    "control_modes": '{"j1": "position"}',
}
SPECIAL = np.array(
    [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -1.7976931348623157e308, 0.1, 1 / 3]
)


def bits(array: object) -> list[int]:
    return np.asarray(array, dtype=np.float64).view(np.uint64).tolist()


def test_every_write_reads_back_exactly(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    nan_payload = np.array([0x7FF8DEADBEEF0001], dtype=np.uint64).view(np.float64)
    state = np.concatenate([SPECIAL, nan_payload])
    blob = bytes(range(256))
    with Recorder(path, metadata=METADATA, attachments={"model.mjcf.xml": b"<mujoco/>"}) as rec:
        rec.write_physics_state(
            PhysicsState(step=0, sim_time_ns=0, state_spec=8191, state=state, qpos=SPECIAL, qvel=[])
        )
        rec.write_applied_input(
            AppliedInput(
                step=1,
                sim_time_ns=2_000_000,
                ctrl=SPECIAL,
                kinematic_joints=["j1", "ä-joint"],
                qpos_index=[0, 4_000_000_000],
                qpos_value=[np.nan, -0.0],
                qvel_index=[2],
                qvel_value=[1e-300],
                mocap_pos=[1.0, 2.0, 3.0],
                mocap_quat=[1.0, 0.0, 0.0, 0.0],
                qfrc_applied=[0.5] * 3,
                xfrc_applied=np.arange(12.0),
            )
        )
        rec.write_bridge_frame(BridgeFrame(
            step=2, sim_time_ns=4_000_000, direction=0, connection=3, seq=0, op="publish",
            topic="/cmd", text='{"op":"publish","msg":"\\u00e9 ✓"}',
        ))  # fmt: skip
        rec.write_bridge_frame(BridgeFrame(
            step=2, sim_time_ns=4_000_000, direction=1, connection=3, seq=2**64 - 1, op="",
            topic="", binary=True, data=blob,
        ))  # fmt: skip
        rec.write_collision_event(CollisionEvent(
            step=3, sim_time_ns=6_000_000, kind=2, robot="arm", body1="a", body2="b",
            geom1="ga", geom2="gb", penetration=0.1, normal_force=-0.0,
            position=(np.nan, 1.0, 2.0), normal=(0.0, 0.0, 1.0), duration_ns=-5, distance=1e-9,
        ))  # fmt: skip
        rec.write_rosout(
            RosoutRecord(
                sim_time_ns=6_000_000,
                level=40,
                name="n",
                msg="m",
                file="f.py",
                function="g",
                line=9,
            )
        )
        rec.write_message(
            "/joint_states",
            "sensor_msgs/msg/JointState",
            {"name": ["j1"], "position": [0.1], "header": {"stamp": {"sec": 1, "nanosec": 5}}},
            sim_time_ns=6_000_000,
        )
        obj = typestore().types["std_msgs/msg/String"](data="hello")
        rec.write_message("/text", "std_msgs/msg/String", obj, sim_time_ns=6_000_000)
    with Recording(path) as r:
        assert r.complete
        assert r.timestep_ns == 2_000_000
        (ps,) = r.physics_states()
        assert (ps.step, ps.sim_time_ns, ps.state_spec) == (0, 0, 8191)
        assert bits(ps.state) == bits(state)
        assert bits(ps.qpos) == bits(SPECIAL)
        assert ps.qvel.size == 0
        (ai,) = r.applied_inputs()
        assert (ai.step, ai.sim_time_ns, ai.kinematic_joints) == (1, 2_000_000, ("j1", "ä-joint"))
        assert bits(ai.ctrl) == bits(SPECIAL)
        assert ai.qpos_index.tolist() == [0, 4_000_000_000]
        assert bits(ai.qpos_value) == bits([np.nan, -0.0])
        assert ai.qvel_index.tolist() == [2]
        assert bits(ai.qvel_value) == bits([1e-300])
        assert ai.mocap_pos.tolist() == [1, 2, 3]
        assert ai.mocap_quat.tolist() == [1, 0, 0, 0]
        assert ai.qfrc_applied.tolist() == [0.5] * 3
        assert ai.xfrc_applied.tolist() == list(range(12))
        text, binary = r.bridge_frames()
        assert text.payload == '{"op":"publish","msg":"\\u00e9 ✓"}'
        assert not text.binary
        assert (text.step, text.direction, text.connection, text.op) == (2, 0, 3, "publish")
        assert binary.payload == blob
        assert binary.binary
        assert binary.seq == 2**64 - 1
        (ev,) = r.collision_events()
        assert (ev.kind, ev.robot, ev.body1, ev.body2, ev.geom1, ev.geom2) == (
            2, "arm", "a", "b", "ga", "gb",
        )  # fmt: skip
        assert bits(ev.position) == bits([np.nan, 1.0, 2.0])
        assert ev.normal == (0.0, 0.0, 1.0)
        assert bits([ev.normal_force]) == bits([-0.0])
        assert (ev.duration_ns, ev.distance, ev.penetration) == (-5, 1e-9, 0.1)
        (log,) = r.messages("/rosout", decode=True)
        assert (log.msg.level, log.msg.msg, log.msg.line, log.msg.stamp.nanosec) == (
            40, "m", 9, 6_000_000,
        )  # fmt: skip
        (js,) = r.messages("/joint_states", decode=True)
        assert js.msg.name == ["j1"]
        assert js.msg.position.tolist() == [0.1]
        assert js.msg.velocity.size == 0
        assert js.msg.header.stamp.nanosec == 5
        assert [m.msg.data for m in r.messages("/text", decode=True)] == ["hello"]
        assert r.attachment("model.mjcf.xml") == b"<mujoco/>"
        assert r.metadata["seed"] == "3"
        assert r.metadata["format_version"] == "1"
        assert r.metadata["timestep_ns"] == "2000000"


@settings(max_examples=25)
@given(
    arrays=st.lists(
        hnp.arrays(np.float64, st.integers(0, 40), elements=st.floats(allow_nan=True)),
        min_size=1,
        max_size=5,
    )
)
def test_physics_states_round_trip_bit_exact(tmp_path_factory, arrays) -> None:
    path = tmp_path_factory.mktemp("h") / "r.mcap"
    with Recorder(path, metadata=METADATA) as rec:
        for step, array in enumerate(arrays):
            rec.write_physics_state(PhysicsState(
                step=step, sim_time_ns=step * 2_000_000, state_spec=1, state=array,
                qpos=array[::-1], qvel=array[:1],
            ))  # fmt: skip
    with Recording(path) as r:
        back = list(r.physics_states())
    assert [s.step for s in back] == list(range(len(arrays)))
    for state, array in zip(back, arrays, strict=True):
        assert bits(state.state) == bits(array)
        assert bits(state.qpos) == bits(array[::-1])
        assert bits(state.qvel) == bits(array[:1])


def test_state_every_and_step_ranges(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    with Recorder(path, metadata=METADATA, state_every=5, chunk_size=512) as rec:
        for step in range(100):
            t = step * 2_000_000
            rec.write_physics_state(
                PhysicsState(step=step, sim_time_ns=t, state_spec=1, state=[step], qpos=[], qvel=[])
            )
            rec.write_applied_input(AppliedInput(step=step, sim_time_ns=t, ctrl=[float(step)]))
    with Recording(path) as r:
        assert len(r.scan.chunks) > 3
        assert [s.step for s in r.physics_states()] == list(range(0, 100, 5))
        assert [s.step for s in r.physics_states(10, 30)] == [10, 15, 20, 25]
        assert [a.step for a in r.applied_inputs(start_step=95)] == list(range(95, 100))
        assert [a.step for a in r.applied_inputs(stop_step=3)] == [0, 1, 2]
        assert r.metadata["state_every"] == "5"
        assert (r.first_step, r.last_step) == (0, 99)


@pytest.mark.parametrize(
    ("metadata", "needle"),
    [
        ({k: v for k, v in METADATA.items() if k != "seed"}, "missing required key 'seed'"),
        ({**METADATA, "timestep": "fast"}, "'timestep' must be a positive number"),
        ({**METADATA, "format_version": "1"}, "'format_version' is written by the recorder"),
        ({**METADATA, "seed": 3}, "key 'seed' must map a string to a string"),
    ],
)
def test_bad_metadata_is_refused(tmp_path: Path, metadata, needle) -> None:
    with pytest.raises(RecordingWriteError, match=needle):
        Recorder(tmp_path / "r.mcap", metadata=metadata)


def test_bad_writes_are_refused(tmp_path: Path) -> None:
    with Recorder(tmp_path / "r.mcap", metadata=METADATA) as rec:
        rec.write_rosout(RosoutRecord(sim_time_ns=10, level=20, name="a", msg="b"))
        with pytest.raises(RecordingWriteError, match="before the last recorded 10"):
            rec.write_rosout(RosoutRecord(sim_time_ns=5, level=20, name="a", msg="b"))
        with pytest.raises(RecordingWriteError, match="already recorded as rcl_interfaces"):
            rec.write_message("/rosout", "std_msgs/msg/String", {"data": "x"}, sim_time_ns=10)
        with pytest.raises(
            RecordingWriteError, match=r"/x \(std_msgs/msg/String\): unknown field 'dat'"
        ):
            rec.write_message("/x", "std_msgs/msg/String", {"dat": "x"}, sim_time_ns=10)
        with pytest.raises(RecordingWriteError, match=r"\.position: expected a list of float64"):
            rec.write_message(
                "/j", "sensor_msgs/msg/JointState", {"position": ["a"]}, sim_time_ns=10
            )
        with pytest.raises(RecordingWriteError, match="unknown message type"):
            rec.write_message("/y", "nope_msgs/msg/Nope", {}, sim_time_ns=10)
        with pytest.raises(RecordingWriteError, match="exactly one of text= or data="):
            rec.write_bridge_frame(
                BridgeFrame(
                    step=0, sim_time_ns=10, direction=0, connection=1, seq=0, op="", topic="",
                    text="{}", data=b"{}",
                )
            )  # fmt: skip
    with pytest.raises(RecordingError, match="recorder is closed"):
        rec.write_rosout(RosoutRecord(sim_time_ns=20, level=20, name="a", msg="b"))
    with pytest.raises(RecordingWriteError, match="cannot create recording"):
        Recorder(tmp_path / "missing" / "r.mcap", metadata=METADATA)


def test_file_without_attachments_still_has_one(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    with Recorder(path, metadata=METADATA):
        pass
    with Recording(path) as r:
        assert r.attachment_names == ["harness_msgs.txt"]
        assert r.message_count == 0
        assert b"harness_msgs/msg/BridgeFrame" in r.attachment("harness_msgs.txt")
        assert r.complete
