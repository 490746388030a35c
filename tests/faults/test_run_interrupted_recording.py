"""An iteration stopped by SIGTERM (or a runner exception) whose recording exists is reported
with it (issue 31, minor): ``results.json`` names the file (``"recording": null`` before the
fix) and the file is a complete recording; a stale file of an earlier run in the same folder,
which the failed iteration never wrote, is not reported as its recording."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from harness.recording import PhysicsState, Recorder, Recording
from harness.scenario.results import IterationSpec
from harness.scenario.runfile import load_run_file
from harness.scenario.runner import iteration_specs, run_one

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "tests" / "data" / "scenario" / "robots" / "two_link.urdf"

# First iteration: exits at once. The second: writes its pid, then hangs without connecting.
CLIENT = """
import os, sys, time
marker = sys.argv[1]
if not os.path.exists(marker):
    open(marker, "w").close()
    sys.exit(0)
with open(marker + ".pid", "w") as f:
    f.write(str(os.getpid()))
time.sleep(600)  # allowed: a client that hangs (the runner must stop it)
"""
ARGS = ("--iterations", "2", "--workers", "1")
METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _scenario(tmp_path: Path) -> Path:
    client = tmp_path / "client.py"
    client.write_text(CLIENT)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        yaml.safe_dump(
            {
                "robots": [{"robot": str(TWO_LINK)}],
                "environment": {"map": "empty"},
                "duration": 0.5,
                "clock": {"mode": "lockstep"},
                "client": {
                    "command": [sys.executable, str(client), str(tmp_path / "started")],
                    "readiness_timeout": 300,
                },
            }
        )
    )
    return scenario


@pytest.mark.timeout(240)
def test_an_interrupted_iteration_reports_its_recording(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path)
    out = tmp_path / "out"
    run = subprocess.Popen(
        [sys.executable, "-m", "harness", "run", str(scenario), *ARGS, "--out", str(out)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    pidfile = tmp_path / "started.pid"
    try:
        deadline = time.monotonic() + 120
        while not pidfile.exists() or not pidfile.read_text():
            assert run.poll() is None, run.communicate()
            assert time.monotonic() < deadline, "the second iteration's client never started"
            time.sleep(0.05)  # allowed: waiting for another process, no simulation here
        os.kill(run.pid, signal.SIGTERM)
        _, stderr = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert run.returncode == 128 + signal.SIGTERM, stderr
    results = json.loads((out / "results.json").read_text())["results"]
    stopped = [r for r in results if r["error"] and "interrupted by SIGTERM" in r["error"]]
    assert len(stopped) == 1, results
    expected = out / "s" / f"iteration-{stopped[0]['iteration']:03d}" / "recording.mcap"
    assert stopped[0]["recording"] == str(expected)
    with Recording(expected, strict=True) as rec:  # closed as a valid file while unwinding
        assert rec.complete
        assert rec.metadata["model_sha256"]


def _spec(tmp_path: Path) -> IterationSpec:
    (spec,) = iteration_specs(load_run_file(_scenario(tmp_path)), tmp_path / "out", 1)
    return spec


def _records_then_raises(spec: IterationSpec):
    with Recorder(spec.recording_path, metadata=METADATA):
        pass
    raise RuntimeError("the client under test crashed the runner")


def _raises(spec: IterationSpec):
    raise RuntimeError("the world did not load")


def test_a_runner_exception_keeps_the_recording_it_wrote_but_not_a_stale_one(
    tmp_path: Path,
) -> None:
    spec = _spec(tmp_path)
    result = run_one(_records_then_raises, spec)
    assert result.error is not None
    assert result.error.startswith("runner raised RuntimeError: the client under test crashed")
    assert result.recording == spec.recording_path

    # The same folder again: the file there is the previous iteration's, not this one's.
    result = run_one(_raises, spec)
    assert result.error is not None
    assert result.error.startswith("runner raised RuntimeError: the world did not load")
    assert result.recording is None
    assert spec.recording_path.is_file()  # left as it was


def test_an_iteration_refused_by_another_writer_does_not_claim_its_recording(
    tmp_path: Path,
) -> None:
    spec = _spec(tmp_path)
    spec.recording_path.parent.mkdir(parents=True)
    with Recorder(spec.recording_path, metadata=METADATA) as other:

        def refused(spec: IterationSpec):
            # the other writer goes on writing while this iteration fails
            q = np.zeros(3)
            other.write_physics_state(PhysicsState(0, 0, 1, q, q, q))
            other.flush()
            with Recorder(spec.recording_path, metadata=METADATA):
                pass

        result = run_one(refused, spec)
    assert result.error is not None
    assert "RecordingBusyError" in result.error
    assert result.recording is None
