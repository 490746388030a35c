"""A recording's schemas and messages are data: ones that do not define or decode as message
types are refused in one line (found by the recording fuzz target; they raised
UnicodeDecodeError, TypesysError, KeyError and SerdeError from rosbags)."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.writer import Writer

from harness.msgs import message_definitions
from harness.recording import Recording, RecordingFormatError

STATE = "harness_msgs/msg/PhysicsState"


def _file(path: Path, schemas: list[tuple[str, bytes]], payload: bytes) -> Path:
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="test")
        writer.add_metadata("harness", {"format_version": "1", "timestep_ns": "2000000"})
        ids = [writer.register_schema(name, "ros2msg", text) for name, text in schemas]
        channel = writer.register_channel("/harness/state", "cdr", ids[0])
        writer.add_message(channel, 0, payload, 0)
        writer.finish()
    return path


@pytest.mark.parametrize(
    ("schemas", "payload", "needle"),
    [
        ([(STATE, b"\xa7\xff not utf-8")], b"", "the file's schemas do not define message types"),
        (
            [(STATE, b"float64 x\n"), (STATE, b"int8 y\n")],
            b"",
            "the file's schemas do not define message types",
        ),
        ([(STATE, b"geometry_msgs/Point p\n")], b"\0\1\0\0", "does not decode as"),
        (
            [(STATE, message_definitions()[STATE].encode())],
            b"\0\1\0\0\1",
            f"message of log time 0 does not decode as '{STATE}'",
        ),
    ],
)
def test_schemas_and_messages_that_do_not_decode_are_one_line(
    tmp_path: Path, schemas: list[tuple[str, bytes]], payload: bytes, needle: str
) -> None:
    path = _file(tmp_path / "odd.mcap", schemas, payload)
    with Recording(path) as rec, pytest.raises(RecordingFormatError) as caught:
        list(rec.physics_states())
    text = str(caught.value)
    assert needle in text
    assert text.startswith(f"{path}: ")
    assert "\n" not in text
    assert len(text) < 600
