"""The example robot project (examples/pick_and_place) runs its own suite, with its golden."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_pick_and_place_example_suite_passes(tmp_path, plugin_args):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "examples/pick_and_place",
            "-q",
            "-p",
            "no:cacheprovider",
            f"--harness-record-dir={tmp_path}",
            *plugin_args,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "2 passed" in proc.stdout
    assert not list(tmp_path.rglob("*.mcap"))  # passing tests keep no recording
