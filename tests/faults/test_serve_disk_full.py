"""``harness serve --record`` on a disk that fills up mid-run (issue 31, minor): it exits
non-zero with one line that says what the recording kept (steps, sim time, messages) and
which steps were lost, and the file it names is valid and ends where the line says.

Before the fix the line was only "recording failed: [Errno 28] No space left on device".
Two ways to run out of room, each limiting only the child: a file size limit (RLIMIT_FSIZE,
any user; Python ignores SIGXFSZ, so writes fail with EFBIG) and, as root, a 3 MiB tmpfs."""

from __future__ import annotations

import os
import re
import resource
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from harness.recording import Recording

# The demo's header and attachments take ~0.85 MB; chunks commit by size (about every 550
# steps), so with 2 MB more room the file keeps whole chunks whatever the wall-clock flushes do.
LIMIT = 3_000_000
LINE = re.compile(
    r"harness serve: error: (?P<path>\S+): recording failed: .*(?P<cause>{cause}); "
    r"recording (?P=path) is a valid file keeping steps 0\.\.(?P<last>\d+) "
    r"\((?P<kept_s>[\d.e+-]+) s of sim time, (?P<messages>\d+) messages\); "
    r"steps (?P<first_lost>\d+)\.\.(?P<reached>\d+) \((?P<lost_s>[\d.e+-]+) s of sim time\) "
    r"were lost$"
)


def _serve_until_full(path: Path, preexec: Callable[[], None] | None) -> str:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "harness",
            "serve",
            "--port",
            "0",
            "--clock",
            "fast",
            *("--record", str(path)),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=preexec,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout.startswith("harness serve: ws://127.0.0.1:")  # it ran, then failed
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


def _check(path: Path, line: str, cause: str) -> None:
    match = re.fullmatch(LINE.pattern.format(cause=re.escape(cause)), line)
    assert match is not None, line
    assert match["path"] == str(path)
    last, reached = int(match["last"]), int(match["reached"])
    assert 0 < last < reached
    assert int(match["first_lost"]) == last + 1
    assert float(match["kept_s"]) == pytest.approx(last * 0.002)
    assert float(match["lost_s"]) == pytest.approx((reached - last) * 0.002)
    with Recording(path, strict=True) as rec:  # strict: any damage raises
        assert rec.complete
        assert rec.message_count == int(match["messages"])
        steps = [s.step for s in rec.physics_states()]
    assert steps == list(range(last + 1))


def test_serve_hitting_a_file_size_limit_says_what_was_kept_and_lost(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, LIMIT))

    line = _serve_until_full(path, limit)
    _check(path, line, "File too large")
    assert path.stat().st_size <= LIMIT


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_serve_on_a_disk_filling_up_says_what_was_kept_and_lost(tmp_path: Path) -> None:
    mount = tmp_path / "small"
    mount.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.decode().strip()}")
    try:
        path = mount / "run.mcap"
        line = _serve_until_full(path, None)
        _check(path, line, "No space left on device")
    finally:
        subprocess.run(["umount", str(mount)], check=True)
