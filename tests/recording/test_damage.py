"""Damaged, truncated, empty, foreign and killed recordings: clear errors, never a traceback."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from mcap.writer import Writer

from harness.cli import main
from harness.recording import (
    PhysicsState,
    Recorder,
    Recording,
    RecordingDamagedWarning,
    RecordingFormatError,
)

HERE = Path(__file__).resolve().parent
METADATA = {
    "timestep": "0.001",
    "integrator": "EULER",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _many_chunks(path: Path, steps: int = 400) -> None:
    with Recorder(path, metadata=METADATA, chunk_size=2048) as rec:
        for step in range(steps):
            rec.write_physics_state(PhysicsState(
                step=step, sim_time_ns=step * 1_000_000, state_spec=1,
                state=[float(step)] * 20, qpos=[0.5], qvel=[0.25],
            ))  # fmt: skip


def _inspect(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, dict, str]:
    code = main(["inspect", str(path), "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out else {}, err


def test_flipped_byte_in_a_chunk(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One bad chunk costs that chunk: the rest of the file, summary included, still reads."""
    path = tmp_path / "r.mcap"
    _many_chunks(path)
    with Recording(path) as r:
        chunks = r.scan.chunks
        assert len(chunks) > 5
        bad = chunks[3]
    raw = bytearray(path.read_bytes())
    raw[bad.offset + bad.length - 10] ^= 0x40  # inside the compressed data
    path.write_bytes(bytes(raw))
    with pytest.warns(RecordingDamagedWarning, match=f"byte {bad.offset}: corrupt"):
        r = Recording(path)
    with r:
        assert len(r.scan.chunks) == len(chunks) - 1
        assert bad.offset not in {c.offset for c in r.scan.chunks}
        assert not r.complete
        assert r.scan.has_summary  # read past the damage
        assert r.scan.truncated_at is None
        steps = [s.step for s in r.physics_states()]
        (lost,) = r.lost
        assert (lost.offset, lost.end) == (bad.offset, bad.offset + bad.length)
        missing = sorted(set(range(400)) - set(steps))
        assert missing  # the bad chunk's states
        assert missing == list(range(missing[0], missing[-1] + 1))
        assert lost.last_step is not None
        assert lost.first_step <= missing[0]  # the lost range is named, and tight
        assert missing[-1] <= lost.last_step
        assert lost.last_step - lost.first_step <= len(missing) + 1
        assert steps[-1] == 399  # everything after the bad chunk
    with pytest.raises(RecordingFormatError, match=f"damaged: byte {bad.offset}"):
        Recording(path, strict=True)
    code, report, err = _inspect(path, capsys)
    assert code == 1
    assert not err
    assert report["verdict"] == "damaged"
    assert report["readable_up_to_byte"] is None
    assert report["problems"][0]["offset"] == bad.offset
    assert report["lost"][0]["first_step"] == lost.first_step
    assert main(["inspect", str(path)]) == 1
    out = capsys.readouterr().out
    assert f"lost: bytes {bad.offset}..{bad.offset + bad.length} passed over" in out
    assert "summary CRC checked" in out  # not "summary missing"


@pytest.mark.parametrize("keep", [0.5, 0.9])
def test_truncated_file(tmp_path: Path, capsys: pytest.CaptureFixture[str], keep: float) -> None:
    path = tmp_path / "r.mcap"
    _many_chunks(path)
    raw = path.read_bytes()
    path.write_bytes(raw[: int(len(raw) * keep)])
    with pytest.warns(RecordingDamagedWarning) as caught:
        r = Recording(path)
    with r:
        message = str(caught[0].message).removeprefix(f"{path}: ")
        assert message.startswith("byte ")
        assert "truncated" in message
        steps = [s.step for s in r.physics_states()]
        assert steps
        assert steps == list(range(len(steps)))
    code, report, err = _inspect(path, capsys)
    assert code == 1
    assert not err
    assert report["verdict"] == "truncated"
    assert report["duration"]["last_step"] == steps[-1]


def test_empty_and_foreign_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    text = tmp_path / "notes.mcap"
    text.write_text("hello, not a recording\n" * 10)
    cases = {empty: "empty file", text: "not an MCAP file", tmp_path / "absent.mcap": "cannot open"}
    for path, needle in cases.items():
        with pytest.raises(RecordingFormatError, match=needle):
            Recording(path)
        code, _, err = _inspect(path, capsys)
        assert code == 2
        assert err.count("\n") == 1
        assert needle in err
        assert "Traceback" not in err


def _foreign_mcap(path: Path, profile: str, metadata: dict[str, str] | None) -> None:
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile=profile)
        if metadata is not None:
            writer.add_metadata("harness", metadata)
        writer.finish()


@pytest.mark.parametrize(
    ("profile", "metadata", "needle"),
    [
        ("", {}, "profile is '', not 'ros2'"),
        ("ros2", None, "no 'harness' metadata record"),
        ("ros2", {"format_version": "99", "timestep_ns": "1000"}, "format version 99 is newer"),
        ("ros2", {"format_version": "x"}, "'format_version' is 'x'"),
    ],
)
def test_wrong_profile_metadata_or_version(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], profile, metadata, needle
) -> None:
    path = tmp_path / "f.mcap"
    _foreign_mcap(path, profile, metadata)
    with pytest.raises(RecordingFormatError, match=needle):
        Recording(path)
    code, _, err = _inspect(path, capsys)
    assert code == 2
    assert needle in err
    assert "Traceback" not in err


@pytest.mark.slow
def test_kill_9_mid_run_keeps_everything_flushed(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    child = subprocess.Popen(
        [sys.executable, str(HERE / "record_run.py"), str(path), "--flush-interval", "0.05"],
        stdout=subprocess.PIPE,
        text=True,
    )
    flushed: list[tuple[int, int]] = []
    try:
        assert child.stdout is not None
        for line in child.stdout:
            if line.startswith("FLUSH "):
                _, sim_time, messages = line.split()
                flushed.append((int(sim_time), int(messages)))
                if len(flushed) == 3:
                    break
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=30)
    assert child.returncode == -signal.SIGKILL
    last_time, last_messages = flushed[-1]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = Recording(path)
    with r:
        assert any(issubclass(w.category, RecordingDamagedWarning) for w in caught)
        assert not r.complete
        assert r.message_count >= last_messages
        assert r.end_time_ns >= last_time
        steps = [s.step for s in r.physics_states()]
        assert steps == list(range(len(steps)))
        assert steps[-1] * r.timestep_ns >= last_time
        assert r.metadata["seed"] == "7"
        assert "model.mjcf.xml" in r.attachment_names
    done = subprocess.run(
        [sys.executable, "-m", "harness", "inspect", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1, done.stderr
    assert "verdict: TRUNCATED: readable up to byte" in done.stdout
    assert "Traceback" not in done.stderr


def test_inspect_reports_a_sound_recording(
    run_recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, report, err = _inspect(run_recording, capsys)
    assert code == 0
    assert not err
    assert report["verdict"] == "ok"
    assert report["problems"] == []
    with Recording(run_recording) as r:
        assert report["duration"]["steps"] == r.last_step - r.first_step + 1
        assert report["duration"]["end_sim_time_ns"] == r.end_time_ns
        assert {t["topic"]: t["messages"] for t in report["topics"]} == {
            t: i.messages for t, i in r.topics.items()
        }
    v = report["validation"]
    assert v["data_section_crc_checked"]
    assert v["summary_crc_checked"]
    assert v["summary_consistency_checks"] >= 8
    assert v["chunk_crcs_checked"] >= 1
    assert report["metadata"]["harness"]["integrator"] == "IMPLICITFAST"
    assert {a["name"] for a in report["attachments"]} == {"model.mjcf.xml", "scenario/run.yaml"}
    assert main(["inspect", str(run_recording)]) == 0
    assert "verdict: OK" in capsys.readouterr().out
