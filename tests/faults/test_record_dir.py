"""A full disk or an unwritable record directory is reported at start: Recorder and Session
construction fail with one clear line (a RecordingError naming the path and the cause) before
anything runs, and ``harness serve --record`` exits 2 with that line."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from harness.errors import RecordingError
from harness.recording import Recorder
from harness.session import Session

METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _one_line(exc: BaseException, *needles: str) -> None:
    text = str(exc)
    assert "\n" not in text
    for needle in needles:
        assert needle in text, text


def _mount_tmpfs(path: Path, options: str) -> bool:
    path.mkdir()
    proc = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
        capture_output=True,
        check=False,
    )
    return proc.returncode == 0


@pytest.fixture
def tiny_tmpfs(tmp_path: Path) -> Iterator[Path]:
    """A 64 KiB file system: the recording's attachments alone do not fit."""
    mount = tmp_path / "tiny"
    if not _mount_tmpfs(mount, "size=64k"):
        pytest.skip("cannot mount a tmpfs here (needs root); /dev/full and RLIMIT_FSIZE cover it")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


@pytest.fixture
def read_only_dir(tmp_path: Path) -> Iterator[Path]:
    folder = tmp_path / "ro"
    if os.geteuid() != 0:
        folder.mkdir()
        folder.chmod(0o555)
        yield folder
        folder.chmod(0o755)
        return
    if not _mount_tmpfs(folder, "ro,size=64k"):
        pytest.skip("root cannot be denied by permissions and no read-only mount is possible")
    yield folder
    subprocess.run(["umount", str(folder)], check=True)


def test_dev_full_fails_the_recorder_at_start() -> None:
    with pytest.raises(RecordingError) as info:
        Recorder("/dev/full", metadata=METADATA, attachments={"a.bin": b"x" * 100_000})
    _one_line(info.value, "/dev/full", "No space left on device")


def test_full_disk_fails_the_session_before_it_runs(tiny_tmpfs: Path) -> None:
    target = tiny_tmpfs / "run.mcap"
    with pytest.raises(RecordingError) as info:
        Session("demo", record_to=target)
    _one_line(info.value, str(target), "No space left on device")
    assert not target.exists()  # no half-written file left behind


@pytest.mark.slow
def test_file_size_limit_fails_the_session_at_start(tmp_path: Path) -> None:
    """RLIMIT_FSIZE below the size of the header and attachments: EFBIG at construction."""
    target = tmp_path / "limited.mcap"
    code = (
        "import resource, sys\n"
        "from harness.errors import HarnessError\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (50_000, 50_000))\n"
        "from harness.session import Session\n"
        "try:\n"
        "    Session('demo', record_to=sys.argv[1])\n"
        "except HarnessError as exc:\n"
        "    print(type(exc).__name__, exc)\n"
        "    sys.exit(3)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(target)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 3, proc.stderr
    assert proc.stdout.startswith("RecordingWriteError")
    assert "File too large" in proc.stdout
    assert len(proc.stdout.strip().splitlines()) == 1


def test_unwritable_record_dir_fails_the_session_at_start(read_only_dir: Path) -> None:
    target = read_only_dir / "run.mcap"
    with pytest.raises(RecordingError) as info:
        Session("demo", record_to=target)
    _one_line(info.value, str(target), "cannot create recording")


@pytest.mark.parametrize("parent", ["missing/dir", "a_file"])
def test_missing_or_bad_record_dir(tmp_path: Path, parent: str) -> None:
    (tmp_path / "a_file").write_text("not a directory")
    target = tmp_path / parent / "run.mcap"
    with pytest.raises(RecordingError) as info:
        Session("demo", record_to=target)
    _one_line(info.value, str(target))


@pytest.mark.slow
def test_serve_reports_a_full_disk_in_one_line() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "harness", "serve", "--port", "0", "--record", "/dev/full"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "No space left on device" in lines[0]
    assert "ws://" not in proc.stdout  # it never started serving
