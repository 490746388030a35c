"""The platform fingerprint (issue 35): recorded in the metadata; replay and diff on another
platform say so in one line and compare only with tolerances; a recording without one is
compared with one note. A foreign platform is faked by rewriting the recorded fingerprint."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from types import ModuleType

import pytest

from harness.cli import main
from harness.recording import Recording
from harness.recording.fingerprint import (
    FINGERPRINT_KEY,
    Fingerprint,
    compare_fingerprints,
    platform_fingerprint,
    recorded_fingerprint,
)
from harness.replay import (
    LevelUnavailableError,
    PlatformMismatchError,
    RecordedDataError,
    VersionMismatchError,
    diff,
    verify,
)

HERE = platform_fingerprint()
# A laptop with AVX-512 and another BLAS core: what issue 35's golden was recorded on.
FOREIGN = dataclasses.replace(
    HERE,
    cpu="Intel(R) Core(TM) i7-1185G7",
    simd=tuple(sorted({*HERE.simd, "avx512f", "avx512vl"})),
    blas=HERE.blas + " SkylakeX",
)


def _with_fingerprint(
    mcap_edit: ModuleType, src: Path, dst: Path, fingerprint: Fingerprint | None
) -> Path:
    def edit(metadata: dict[str, str]) -> dict[str, str]:
        out = {k: v for k, v in metadata.items() if k != FINGERPRINT_KEY}
        if fingerprint is not None:
            out[FINGERPRINT_KEY] = fingerprint.to_json()
        return out

    return mcap_edit.rewrite(src, dst, metadata=edit)  # type: ignore[no-any-return]


def test_this_platform_is_printed_and_recorded(base_recording: Path) -> None:
    print(f"\nthis machine's fingerprint: {HERE.to_json()}")
    assert HERE.machine
    assert HERE.mujoco.startswith(__import__("mujoco").__version__)
    assert set(HERE.simd) <= {
        "sse4_2", "avx", "f16c", "fma", "avx2", "avx512f", "avx512cd", "avx512bw", "avx512dq",
        "avx512vl", "asimd", "sve", "sve2",
    }  # fmt: skip
    with Recording(base_recording) as rec:
        raw = json.loads(rec.metadata[FINGERPRINT_KEY])
        assert raw["schema"] == 1
        assert recorded_fingerprint(rec.metadata) == HERE
    assert compare_fingerprints(HERE, HERE).same is True


def test_the_cpu_model_alone_is_not_another_platform() -> None:
    renamed = dataclasses.replace(HERE, cpu="another model of the same generation")
    assert compare_fingerprints(HERE, renamed).same is True
    found = compare_fingerprints(FOREIGN, HERE, ("in the recording", "here"))
    assert found.same is False
    assert found.text.startswith("simd: avx512f avx512vl only in the recording; blas: ")
    assert "cpu: Intel(R) Core(TM) i7-1185G7 in the recording" in found.text


def test_replay_of_a_foreign_recording_refuses_bit_exact_in_one_line(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    foreign = _with_fingerprint(mcap_edit, base_recording, tmp_path / "laptop.mcap", FOREIGN)
    with pytest.raises(PlatformMismatchError, match=r"another platform \(simd: avx512f avx512vl"):
        verify(foreign)
    # the CLI: one line on stderr, exit 2, naming what differs and how to compare
    assert main(["replay", str(foreign)]) == 2
    err = capsys.readouterr().err
    print(f"\nforeign-fingerprint message: {err.strip()}")
    assert err.count("\n") == 1
    assert "simd: avx512f avx512vl only in the recording" in err
    assert "--atol" in err
    # the same class as the MuJoCo version mismatch, so callers catching that catch this
    assert issubclass(PlatformMismatchError, VersionMismatchError)
    # with tolerances: compared, and one note says on what
    report = verify(foreign, atol=1e-9)
    assert report.reproduced
    notes = [n for n in report.notes if "platform" in n]
    assert len(notes) == 1
    assert notes[0].startswith("recorded on another platform (simd: avx512f avx512vl")
    assert "note: recorded on another platform" in report.format()
    with pytest.raises(
        LevelUnavailableError, match=r"another platform.*--level full.*same platform"
    ):
        verify(foreign, atol=1e-9, level="full")


def test_replay_of_a_recording_without_fingerprint_says_so_once(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    old = _with_fingerprint(mcap_edit, base_recording, tmp_path / "old.mcap", None)
    report = verify(old)
    assert report.reproduced
    assert [n for n in report.notes if "fingerprint" in n] == [
        "no platform fingerprint in the recording (made before harness recorded one): "
        "platforms not compared"
    ]
    same = verify(base_recording)
    assert not [n for n in same.notes if "platform" in n]


def test_a_malformed_fingerprint_is_one_line_naming_the_key(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path
) -> None:
    text = json.dumps({**json.loads(HERE.to_json()), "simd": "avx avx2"})
    bad = mcap_edit.rewrite(
        base_recording, tmp_path / "bad.mcap", metadata=lambda m: {**m, FINGERPRINT_KEY: text}
    )
    with pytest.raises(RecordedDataError, match=r"bad.mcap: metadata 'fingerprint': 'simd' is"):
        verify(bad)
    partial = mcap_edit.rewrite(
        base_recording,
        tmp_path / "partial.mcap",
        metadata=lambda m: {**m, FINGERPRINT_KEY: '{"schema": 1}'},
    )
    with pytest.raises(RecordedDataError, match=r"partial.mcap: metadata 'fingerprint': no 'cpu'"):
        diff(partial, base_recording)


def test_diff_of_recordings_from_two_platforms(
    base_recording: Path, mcap_edit: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    foreign = _with_fingerprint(mcap_edit, base_recording, tmp_path / "laptop.mcap", FOREIGN)
    with pytest.raises(
        PlatformMismatchError, match=r"different platforms \(simd: avx512f avx512vl only in A"
    ):
        diff(foreign, base_recording)
    assert main(["diff", str(foreign), str(base_recording)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--joint-position" in err
    # with tolerances they are compared, and the report says on what platforms
    report = diff(foreign, base_recording, joint_position=1e-9, joint_velocity=1e-7)
    assert report.same
    assert report.notes[0].startswith("recorded on different platforms (simd: avx512f avx512vl")
    # an old recording: one note, compared exactly
    old = _with_fingerprint(mcap_edit, base_recording, tmp_path / "old.mcap", None)
    report = diff(old, base_recording)
    assert report.same
    assert report.notes == (
        "no platform fingerprint in A (made before harness recorded one): platforms not compared",
    )
