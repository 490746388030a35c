"""Independent readers decode every message of a realistic recording."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from rosbags.highlevel import AnyReader

from harness.recording import Recording
from harness.recording.convert import to_plain

from .conftest import STEPS

NODE_DIR = Path(__file__).resolve().parents[1] / "node"
EXPECTED_TOPICS = {
    "/robot_description": "std_msgs/msg/String",
    "/rosout": "rcl_interfaces/msg/Log",
    "/harness/state": "harness_msgs/msg/PhysicsState",
    "/harness/bridge": "harness_msgs/msg/BridgeFrame",
    "/harness/inputs": "harness_msgs/msg/AppliedInput",
    "/harness/collisions": "harness_msgs/msg/CollisionEvent",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/clock": "rosgraph_msgs/msg/Clock",
    "/tf": "tf2_msgs/msg/TFMessage",
}


def _ours(path: Path) -> list[tuple[str, int, object]]:
    with Recording(path) as recording:
        return [(m.topic, m.sim_time_ns, to_plain(m.msg)) for m in recording.messages(decode=True)]


def test_layout_is_complete(run_recording: Path) -> None:
    with Recording(run_recording) as recording:
        assert recording.complete
        assert {t: i.msgtype for t, i in recording.topics.items()} == EXPECTED_TOPICS
        assert recording.topics["/harness/state"].messages == STEPS + 1
        frames = list(recording.bridge_frames())
        assert any(f.binary for f in frames)
        assert any(not f.binary and f.direction == 0 for f in frames)
        assert [f.seq for f in frames] == list(range(len(frames)))
        assert any(e.kind == 0 for e in recording.collision_events())
        assert set(recording.attachment_names) == {"model.mjcf.xml", "scenario/run.yaml"}
        assert recording.metadata["mujoco_version"]


def test_rosbags_anyreader_decodes_everything(run_recording: Path) -> None:
    ours = _ours(run_recording)
    theirs = []
    with AnyReader([run_recording]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == EXPECTED_TOPICS
        for connection, timestamp, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            theirs.append((connection.topic, timestamp, to_plain(msg)))
    assert len(theirs) == len(ours)
    assert theirs == ours


def test_mcap_stream_reader_validates_crcs(run_recording: Path) -> None:
    counts: Counter[str] = Counter()
    channels: dict[int, str] = {}
    last_time = -1
    with open(run_recording, "rb") as f:
        for record in StreamReader(f, validate_crcs=True).records:
            name = type(record).__name__
            if name == "Channel":
                channels[record.id] = record.topic
                assert record.message_encoding == "cdr"
                assert set(record.metadata) == {"offered_qos_profiles", "topic_type_hash"}
                assert record.metadata["topic_type_hash"].startswith("RIHS01_")
            elif name == "Schema":
                assert record.encoding == "ros2msg"
            elif name == "Message":
                counts[channels[record.channel_id]] += 1
                assert record.log_time >= last_time
                last_time = record.log_time
            elif name == "Header":
                assert record.profile == "ros2"
            elif name == "DataEnd":
                assert record.data_section_crc != 0
    with open(run_recording, "rb") as f:
        indexed = Counter(
            ch.topic for _, ch, _ in make_reader(f, validate_crcs=True).iter_messages()
        )
    with Recording(run_recording) as recording:
        expected = {t: i.messages for t, i in recording.topics.items()}
    assert dict(counts) == expected == dict(indexed)


@pytest.mark.slow
def test_rosbags_convert_to_sqlite3_and_back(run_recording: Path, tmp_path: Path) -> None:
    exe = Path(sys.executable).parent / "rosbags-convert"
    sqlite_dir, back_dir = tmp_path / "sqlite", tmp_path / "back"
    for src, dst, storage in (
        (run_recording, sqlite_dir, "sqlite3"),
        (sqlite_dir, back_dir, "mcap"),
    ):
        done = subprocess.run(
            [str(exe), "--src", str(src), "--dst", str(dst), "--dst-storage", storage],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
    assert list(sqlite_dir.glob("*.db3"))
    with AnyReader([back_dir]) as reader:
        back = [
            (c.topic, t, to_plain(reader.deserialize(raw, c.msgtype)))
            for c, t, raw in reader.messages()
        ]
    assert back == _ours(run_recording)


@pytest.mark.node
def test_foxglove_decoders_read_everything(run_recording: Path) -> None:
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "@mcap" / "core").is_dir():
        pytest.skip("node or tests/node/node_modules missing (make test installs them)")
    done = subprocess.run(
        [node, str(NODE_DIR / "mcap_read.mjs"), str(run_recording)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=NODE_DIR,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    stream, indexed = result["stream"], result["indexed"]
    ours = _ours(run_recording)
    assert stream["header"]["profile"] == "ros2"
    assert stream["metadata"]["harness"]["format_version"] == "1"
    assert len(stream["messages"]) == len(ours) == indexed["decoded"]
    assert indexed["statistics_messages"] == str(len(ours))
    assert indexed["attachments"] == 2
    for theirs, (topic, sim_time_ns, msg) in zip(stream["messages"], ours, strict=True):
        assert (theirs["topic"], int(theirs["log_time"]), theirs["encoding"]) == (
            topic,
            sim_time_ns,
            "cdr",
        )
        assert _normalise(theirs["msg"]) == _normalise(msg), topic
    assert indexed["counts"] == dict(Counter(t for t, _, _ in ours))


def _normalise(value: object) -> object:
    """JSON view of a decoded message: int64/uint64 come from node as strings, floats exact."""
    if isinstance(value, dict):
        return {k: _normalise(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_normalise(v) for v in value]
    if isinstance(value, str) and value.lstrip("-").isdigit():
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    return value
