"""The ``harness`` command's warnings (issue 34, finding 9): one line ``harness: warning:
<message>`` without the source line of the harness code that raised it, each said once, also
when a command loads the same robot twice (a replay re-simulation rebuilds it in a fresh
temporary folder)."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from harness.models.errors import ModelWarning
from harness.session import Session

FLOATING = Path(__file__).resolve().parent / "data" / "sensors" / "sensor_model.sdf"


def test_the_warning_lines_are_one_line_and_said_once():
    from harness.cli_warnings import one_line_warnings

    out = io.StringIO()
    with one_line_warnings(stream=out):
        warnings.warn("/tmp/a/robot.sdf: floating base lifted\n0.05 m", ModelWarning, stacklevel=1)
        warnings.warn("/tmp/b/robot.sdf: floating base lifted 0.05 m", ModelWarning, stacklevel=1)
        warnings.warn("another thing", UserWarning, stacklevel=1)
    assert out.getvalue().splitlines() == [
        "harness: warning: /tmp/a/robot.sdf: floating base lifted 0.05 m",
        "harness: warning: another thing",
    ]


def test_replay_re_simulation_says_the_load_note_once_in_one_line(tmp_path):
    path = tmp_path / "run.mcap"
    with pytest.warns(ModelWarning, match="floating base lifted"):
        session = Session(FLOATING, record_to=path)
    with session:
        session.step(10)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    result = subprocess.run(
        [sys.executable, "-m", "harness.cli", "replay", str(path), "--actuation", "servo"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    warned = [line for line in lines if "floating base lifted" in line]
    assert len(warned) == 1, lines
    assert warned[0].startswith("harness: warning: ")
    assert not any("ModelWarning" in line or "load_robot(" in line for line in lines), lines
