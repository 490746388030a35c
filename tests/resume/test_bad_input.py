"""What a resume refuses, one line each and exit code 2: a step beyond the recording, a
damaged stretch before the step, a recording of another MuJoCo or harness version, a step
inside a client's /harness/step request, a wrong fork edit, serve options that say what to
simulate."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness import Session
from harness.cli import main
from harness.recording import Recording, RecordingDamagedWarning
from harness.resume import ForkEditError, ResumeError, ResumeStepError, ResumeVersionError

from .conftest import ARM_FORK, ARM_STEPS, load_helper


def _serve(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    assert main(["serve", "--port", "0", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # one line, no traceback
    return err


def test_a_step_beyond_the_recording(arm_parent: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = _serve(capsys, "--from", str(arm_parent), "--at", str(ARM_STEPS + 1))
    assert f"step {ARM_STEPS + 1} is beyond the recording: it ends at step {ARM_STEPS}" in err
    assert str(arm_parent) in err
    err = _serve(capsys, "--from", str(arm_parent), "--at-time", "2.5")
    assert "step 1250 is beyond the recording" in err
    with pytest.raises(ResumeStepError, match="beyond the recording"):
        Session.resume(arm_parent, step=ARM_STEPS + 1)


def test_a_step_inside_a_step_request(arm_parent: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = _serve(capsys, "--from", str(arm_parent), "--at", str(ARM_FORK + 20))
    assert (
        f"step {ARM_FORK + 20} lies inside connection 1's /harness/step request (steps "
        f"{ARM_FORK}..{ARM_FORK + 50}): resume at step {ARM_FORK} or {ARM_FORK + 50}"
    ) in err


def _rechunked(parent: Path, out: Path) -> Path:
    mcap_edit = load_helper("replay", "mcap_edit")
    return mcap_edit.rewrite(parent, out, chunk_size=64 * 1024)  # type: ignore[no-any-return]


def test_a_damaged_stretch_before_the_step(
    arm_parent: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sound = _rechunked(arm_parent, tmp_path / "sound.mcap")
    with Recording(sound) as rec:
        chunks = rec.scan.chunks
        bad = chunks[len(chunks) // 2]
    raw = bytearray(sound.read_bytes())
    raw[bad.offset + bad.length // 2] ^= 0x10
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(raw))
    with pytest.warns(RecordingDamagedWarning), Recording(damaged) as rec:
        (lost,) = rec.lost
    assert 0 < lost.first_step < ARM_STEPS
    err = _serve(capsys, "--from", str(damaged), "--at", str(ARM_STEPS))
    assert f"{damaged}: damaged before step {ARM_STEPS} (bytes {bad.offset}.." in err
    assert f"resume at step {lost.first_step - 1} or earlier" in err
    # before the damage it resumes: what it re-runs is intact
    before = (lost.first_step - 1) // 50 * 50
    with Session.resume(damaged, step=before) as session:
        assert session.step_index == before


@pytest.mark.parametrize(
    ("key", "what"), [("mujoco_version", "MuJoCo"), ("harness_version", "harness")]
)
def test_a_recording_of_another_version(
    arm_parent: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, what: str
) -> None:
    mcap_edit = load_helper("replay", "mcap_edit")
    other = mcap_edit.rewrite(
        arm_parent, tmp_path / "other.mcap", metadata=lambda m: {**m, key: "0.0.1"}
    )
    err = _serve(capsys, "--from", str(other), "--at", str(ARM_FORK))
    assert f"{other}: recorded with {what} 0.0.1, this is {what} " in err
    with pytest.raises(ResumeVersionError):
        Session.resume(other, step=ARM_FORK)


def test_wrong_edits_and_options(
    arm_parent: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = _serve(capsys, "--from", str(arm_parent), "--at", "0", "--set", "joint.elbow=1")
    assert "fork edit joint.elbow=1.0: no controllable joint 'elbow' (joints: " in err
    err = _serve(capsys, "--from", str(arm_parent), "--set", "gain=1")
    assert "fork edit 'gain=1' is not KIND.TARGET=VALUE" in err
    err = _serve(capsys, "--from", str(arm_parent), "--robot", "other.urdf")
    assert "--robot does not apply with --from" in err
    err = _serve(capsys, "--at", "3")
    assert "--at, --at-time and --set need --from RUN.mcap" in err
    with pytest.raises(ForkEditError):
        Session.resume(arm_parent, step=0, edits=["joint.joint1=nan"])
    child = tmp_path / "child.mcap"
    with pytest.raises(ForkEditError):
        Session.resume(arm_parent, step=ARM_FORK, record_to=child, edits=["joint.elbow=1"])
    assert not child.exists()  # a resume that did not start leaves no child
    assert issubclass(ForkEditError, ResumeError)
