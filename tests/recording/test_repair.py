"""``harness repair``: a kill -9 file and a file with a bad chunk become complete recordings
that rosbags, the mcap library (CRCs checked, through the summary) and Foxglove's
``@mcap/core`` read, holding every intact message."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import warnings
from collections import Counter
from pathlib import Path
from types import ModuleType

import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from rosbags.highlevel import AnyReader
from rosbags.highlevel import AnyReaderError as ReaderError

from harness.cli import main
from harness.recording import Recording, RecordingWriteError
from harness.recording.repair import repair

HERE = Path(__file__).resolve().parent
NODE_DIR = HERE.parent / "node"


def _open(path: Path) -> Recording:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Recording(path)


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    with _open(path) as rec:
        return [(m.topic, m.sim_time_ns, m.data) for m in rec.messages()]


@pytest.fixture(scope="module")
def killed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("killed") / "killed.mcap"
    child = subprocess.Popen(
        [sys.executable, str(HERE / "record_run.py"), str(path), "--flush-interval", "0.05"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None
        flushes = 0
        for line in child.stdout:
            flushes += line.startswith("FLUSH ")
            if flushes == 3:
                break
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=30)
    return path


def _check_readers(path: Path, expected: list[tuple[str, int, bytes]]) -> None:
    counts = Counter(topic for topic, _, _ in expected)
    with AnyReader([path]) as reader:
        theirs = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
    assert theirs == expected
    with open(path, "rb") as f:
        streamed = Counter(type(r).__name__ for r in StreamReader(f, validate_crcs=True).records)
    assert streamed["Message"] == len(expected)
    assert streamed["Footer"] == 1
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        assert summary.statistics is not None
        assert summary.statistics.message_count == len(expected)
        indexed = Counter(ch.topic for _, ch, _ in reader.iter_messages())
    assert indexed == counts
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "@mcap" / "core").is_dir():
        return  # the node check runs where make test installed tests/node
    done = subprocess.run(
        [node, str(NODE_DIR / "mcap_read.mjs"), str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=NODE_DIR,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert len(result["stream"]["messages"]) == len(expected)
    assert result["indexed"]["decoded"] == len(expected)
    assert result["indexed"]["counts"] == dict(counts)


def test_a_killed_recording_is_repaired(
    killed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with _open(killed) as rec:
        assert not rec.complete
        attachments = rec.attachments
        metadata = rec.all_metadata
    expected = _messages(killed)
    assert len(expected) > 10
    with pytest.raises(ReaderError, match=r"(?i)magic"):  # what the repair is for
        AnyReader([killed]).open()
    out = tmp_path / "repaired.mcap"
    assert main(["repair", str(killed), str(out)]) == 0
    text = capsys.readouterr().out
    assert "truncated" in text
    assert f"{len(expected)} messages" in text
    with Recording(out) as rec:
        assert rec.complete
        assert rec.attachments == attachments
        assert rec.all_metadata == metadata
    assert _messages(out) == expected
    _check_readers(out, expected)


def test_a_bad_chunk_is_left_out_and_named(record_run: ModuleType, tmp_path: Path) -> None:
    sound = tmp_path / "sound.mcap"
    record_run.record(sound, 300, chunk_size=16 * 1024)
    with Recording(sound) as rec:
        chunks = rec.scan.chunks
    assert len(chunks) > 4
    bad = chunks[len(chunks) // 2]
    raw = bytearray(sound.read_bytes())
    raw[bad.offset + bad.length // 2] ^= 0x08
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(raw))
    expected = _messages(damaged)
    report = repair(damaged, tmp_path / "fixed.mcap")
    assert report.chunks == len(chunks) - 1
    assert [r.offset for r in report.lost] == [bad.offset]
    assert "lost: bytes" in report.format()
    _check_readers(tmp_path / "fixed.mcap", expected)


def test_repair_refuses_its_own_source(run_recording: Path) -> None:
    with pytest.raises(RecordingWriteError, match="another target"):
        repair(run_recording, run_recording)
