"""Recordings that cannot be replayed bit for bit: clear one-line errors, CLI exit code 2."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest

from harness.cli import main
from harness.errors import HarnessError, RecordingError
from harness.replay import (
    LevelUnavailableError,
    ModelAttachmentError,
    RecordedDataError,
    VersionMismatchError,
    verify,
)


def test_truncated_recording_is_refused_then_replayed_up_to_the_damage(
    helper: ModuleType, tmp_path: Path
) -> None:
    path = helper.record(tmp_path / "small-chunks.mcap", {0: {"joint1": 0.3}}, 300, chunk_size=8192)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 30_000])  # inside the data section, after attachments
    with pytest.raises(RecordedDataError, match=r"damaged \(byte \d+: truncated.*--allow-damaged"):
        verify(cut)
    report = verify(cut, allow_damaged=True)
    assert report.reproduced
    assert 0 < report.last_step < 300
    assert report.notes
    assert "damaged recording" in report.notes[0]


def test_corrupt_chunk_is_refused(base_recording: Path, tmp_path: Path) -> None:
    data = bytearray(base_recording.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 16] = bytes(16)
    bad = tmp_path / "corrupt.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(HarnessError, match=r"corrupt.mcap.*(damaged|corrupt)"):
        verify(bad)


def test_not_a_recording(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello, not mcap")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        verify(junk)
    assert main(["replay", str(junk)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "junk.mcap" in err


def test_other_mujoco_version_needs_a_tolerance(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    other = mcap_edit.rewrite(
        base_recording,
        tmp_path / "old.mcap",
        metadata=lambda m: {**m, "mujoco_version": "3.17.0"},
    )
    with pytest.raises(VersionMismatchError, match=r"MuJoCo 3\.17\.0.*--atol"):
        verify(other)
    report = verify(other, atol=1e-9)
    assert report.reproduced
    assert report.mujoco_recorded == "3.17.0"


def test_wrong_model_attachment(
    base_recording: Path, helper: ModuleType, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    foreign = helper.demo_robot("kinematic").mjcf.encode()

    def swap(attachments: dict[str, bytes]) -> dict[str, bytes]:
        return {"model.mjcf.xml": foreign}

    wrong = mcap_edit.rewrite(base_recording, tmp_path / "wrong.mcap", attachments=swap)
    with pytest.raises(ModelAttachmentError, match=r"SHA-256.*not the model"):
        verify(wrong)


def test_mjb_of_another_model_is_caught_by_state_size(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    import mujoco

    other = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><joint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    blob_path = tmp_path / "other.mjb"
    mujoco.mj_saveModel(other, str(blob_path), None)
    wrong = mcap_edit.rewrite(
        base_recording,
        tmp_path / "wrongmjb.mcap",
        attachments=lambda a: {**a, "model.mjb": blob_path.read_bytes()},
    )
    with pytest.raises(RecordedDataError, match="does not belong to this recording"):
        verify(wrong)


def test_missing_states(base_recording: Path, mcap_edit: ModuleType, tmp_path: Path) -> None:
    empty = mcap_edit.rewrite(
        base_recording,
        tmp_path / "nostates.mcap",
        edit=lambda topic, msg: None if topic == "/harness/state" else msg,
    )
    with pytest.raises(RecordedDataError, match="no physics states"):
        verify(empty)


def test_full_level_is_refused_clearly(base_recording: Path) -> None:
    with pytest.raises(LevelUnavailableError, match="--level physics"):
        verify(base_recording, level="full")
