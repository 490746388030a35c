"""Damage costs only what is damaged: a bad chunk in the middle loses its steps and the replay
starts again after it; a bad ``model.mjb`` falls back to the next model attachment, saying so."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest

from harness.cli import main
from harness.recording import Recording
from harness.replay import verify
from harness.replay.errors import RecordedDataError


def _flip_chunk(src: Path, dst: Path, which: float) -> tuple[int, int]:
    """Flip a byte inside the compressed data of the chunk ``which`` of the way in; return
    that chunk's (offset, length)."""
    with Recording(src) as rec:
        chunks = rec.scan.chunks
        bad = chunks[int(len(chunks) * which)]
    raw = bytearray(src.read_bytes())
    raw[bad.offset + bad.length // 2] ^= 0x10
    dst.write_bytes(bytes(raw))
    return bad.offset, bad.length


@pytest.mark.parametrize("control", ["position", "kinematic"])
def test_a_bad_chunk_costs_its_steps_only(
    helper: ModuleType, tmp_path: Path, control: str, capsys: pytest.CaptureFixture[str]
) -> None:
    sound = helper.record(
        tmp_path / "sound.mcap",
        {0: helper.REACH, 120: helper.BACK, 190: helper.REACH},
        300,
        control=control,
        chunk_size=16 * 1024,
    )
    path = tmp_path / "bad.mcap"
    offset, _ = _flip_chunk(sound, path, 0.4)
    with pytest.raises(RecordedDataError, match="damaged"):
        verify(path)
    report = verify(path, allow_damaged=True)
    assert report.reproduced, report.format()
    (note,) = [n for n in report.notes if n.startswith(f"bytes {offset}..")]
    with Recording(path) as rec:
        (lost,) = rec.lost
        states = rec.physics_state_arrays().steps
    assert lost.last_step is not None
    assert f"steps {lost.first_step}..{lost.last_step} may be missing" in note
    assert report.last_step == 300  # the replay went on to the end
    lost_states = 301 - states.size
    assert 0 < lost_states < 60  # one chunk's worth
    # Every intact state was compared but the first of each stretch (the starting points).
    if control == "position":
        assert report.states_compared == states.size - 2
    else:  # kinematic joints: the replay waits for the next recorded input after the damage
        assert states.size - 2 - 70 <= report.states_compared < states.size - 2
    assert main(["replay", str(path), "--allow-damaged"]) == 0
    assert "REPRODUCED" in capsys.readouterr().out


def test_a_bad_mjb_falls_back_with_a_notice(base_recording: Path, tmp_path: Path) -> None:
    with Recording(base_recording) as rec:
        (mjb,) = [a for a in rec.scan.attachments if a.name == "model.mjb"]
    raw = bytearray(base_recording.read_bytes())
    raw[mjb.data_offset + mjb.data_length // 2] ^= 0x01
    path = tmp_path / "bad-mjb.mcap"
    path.write_bytes(bytes(raw))
    with pytest.warns(match="model.mjb' CRC mismatch"):
        rec = Recording(path)
    with rec:
        assert rec.message_count > 300  # every chunk after the attachment still reads
        assert "model.mjb" not in rec.attachments
    report = verify(path, allow_damaged=True)
    assert report.reproduced, report.format()
    assert report.model_source.startswith("source attachments (rebuilt")
    assert "fell back: model.mjb" in report.model_source
    assert "CRC mismatch" in report.model_source
