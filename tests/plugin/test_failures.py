"""A failed test read in one look (issue 35): the ``harness`` section ends with the commands
that reproduce, compare, replay and open the run; ``--harness-keep-recordings=failed`` leaves
one folder per failed test for CI to upload; a golden from another platform is checked only
with tolerances, one without a fingerprint is said once."""

from __future__ import annotations

import dataclasses
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from harness.recording import Recording
from harness.recording.fingerprint import FINGERPRINT_KEY, platform_fingerprint
from tests.plugin.test_plugin import MOVE
from tests.replay.mcap_edit import rewrite

GOLDEN = Path("recordings") / "test_golden" / "test_move.mcap"
FOREIGN = dataclasses.replace(
    platform_fingerprint(),
    cpu="Intel(R) Core(TM) i7-1185G7",
    simd=tuple(sorted({*platform_fingerprint().simd, "avx512f", "avx512vl"})),
)


def _section(stdout: str) -> list[str]:
    """The ``harness`` section's lines."""
    text = stdout.split("-- harness --", 1)[1]
    text = text.split("=== short test summary", 1)[0].rsplit("\n", 1)[0]
    return [line for line in text.strip().splitlines() if line.strip()]


def _refingerprint(golden: Path, fingerprint: str | None) -> None:
    """Rewrite ``golden`` as if written on another platform (or by an older harness)."""
    copy = golden.with_suffix(".tmp")

    def edit(metadata: dict[str, str]) -> dict[str, str]:
        out = {k: v for k, v in metadata.items() if k != FINGERPRINT_KEY}
        return out if fingerprint is None else {**out, FINGERPRINT_KEY: fingerprint}

    rewrite(golden, copy, metadata=edit)
    copy.replace(golden)


@pytest.mark.slow  # three runs of the commands it prints
def test_golden_mismatch_section_ends_with_the_commands(pytester, run):
    pytester.makepyfile(test_golden=MOVE)
    run("--harness-update-goldens").assert_outcomes(passed=1)
    (pytester.path / "target.txt").write_text("0.1")
    result = run()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    print(out[out.index("___ test_move ___") - 30 :])
    lines = _section(out)
    folder = pytester.path / ".harness/recordings/test_golden/test_move"
    recording, snapshot = folder / "test_move.mcap", folder / "test_move.snapshot.mcap"
    assert [line[:11] for line in lines[-4:]] == [
        "reproduce: ",
        "diff:      ",
        "replay:    ",
        "open:      ",
    ]
    commands = {line[:10].strip(): line[11:] for line in lines[-4:]}
    assert commands["reproduce:"] == "python -m pytest test_golden.py::test_move"
    assert commands["diff:"] == f"harness diff {pytester.path / GOLDEN} {snapshot}"
    assert commands["replay:"] == f"harness replay {recording}"
    assert commands["open:"].startswith(f"foxglove-studio {recording}  # ")
    # each command does what it says: the test fails again, the diff names the divergence,
    # the replay reproduces the recording
    again = subprocess.run(
        [sys.executable, *shlex.split(commands["reproduce:"])[1:], "-p", "no:cacheprovider"],
        cwd=pytester.path, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert again.returncode == 1, again.stdout[-2000:]
    assert "GoldenMismatch" in again.stdout
    compared = subprocess.run(
        [sys.executable, "-m", *shlex.split(commands["diff:"])],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert compared.returncode == 1, compared.stdout + compared.stderr
    assert "FIRST DIVERGENCE at step" in compared.stdout
    replayed = subprocess.run(
        [sys.executable, "-m", *shlex.split(commands["replay:"])],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr


FAILING_CLASSES = """
class TestLeft:
    def test_arm(self, harness_session):
        harness_session.step(3)
        assert False, "left"

class TestRight:
    def test_arm(self, harness_session):
        harness_session.step(3)
        assert False, "right"

def test_passes(harness_session):
    harness_session.step(3)
"""


def test_failed_tests_leave_one_folder_each_for_ci(pytester, run):
    pytester.makepyfile(test_ci=FAILING_CLASSES)
    run().assert_outcomes(passed=1, failed=2)
    root = pytester.path / ".harness" / "recordings"
    folders = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_dir())
    # two classes with one method name: two folders (they shared one file before)
    assert folders == ["test_ci", "test_ci/TestLeft.test_arm", "test_ci/TestRight.test_arm"]
    for side in ("Left", "Right"):
        folder = root / "test_ci" / f"Test{side}.test_arm"
        assert sorted(p.name for p in folder.iterdir()) == ["failure.txt", "test_arm.mcap"]
        note = (folder / "failure.txt").read_text()
        assert note.startswith(f"test_ci.py::Test{side}::test_arm failed: AssertionError: ")
        assert f"reproduce: python -m pytest test_ci.py::Test{side}::test_arm" in note
        with Recording(folder / "test_arm.mcap") as rec:
            assert rec.last_step == 3


def test_golden_from_another_platform_needs_tolerances(pytester, run):
    pytester.makepyfile(test_golden=MOVE)
    run("--harness-update-goldens").assert_outcomes(passed=1)
    _refingerprint(pytester.path / GOLDEN, FOREIGN.to_json())
    result = run()
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    line = next(x for x in out.splitlines() if "was recorded on another platform" in x)
    print(f"\n{line}")
    assert "During handling" not in out
    assert line.startswith(
        "golden recordings/test_golden/test_move.mcap was recorded on another "
        "platform (simd: avx512f avx512vl only in the golden; cpu: Intel(R) Core(TM) i7-1185G7 "
        "in the golden, "
    )
    assert "golden.check(joint_position=1e-9, joint_velocity=1e-7)" in line
    assert line.endswith("python -m pytest test_golden.py::test_move --harness-update-goldens")
    assert "golden:    recorded on another platform (simd: avx512f" in out
    # with tolerances the golden is compared (the run is the same: it passes)
    pytester.makepyfile(
        test_golden=MOVE.replace("TOLERANCES = {}", "TOLERANCES = dict(joint_position=1e-9)")
    )
    run().assert_outcomes(passed=1)


def test_golden_without_fingerprint_is_said_once(pytester, run):
    pytester.makepyfile(test_golden=MOVE)
    run("--harness-update-goldens").assert_outcomes(passed=1)
    _refingerprint(pytester.path / GOLDEN, None)
    result = run()
    result.assert_outcomes(passed=1)
    out = result.stdout.str()
    assert out.count("harness goldens without a platform fingerprint") == 1
    result.stdout.fnmatch_lines(
        [
            "*harness goldens without a platform fingerprint*",
            "1 golden(s) written by an older harness: checked as if recorded on this platform*",
            f"{pytester.path / GOLDEN}",
        ]
    )
