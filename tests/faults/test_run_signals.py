"""``harness run`` and stop signals: SIGTERM and SIGINT stop the iterations (the running
client's process group stopped), the reports are written for the iterations that ran, the
exit code is 128 + the signal, and no process is left behind (worker, client)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "tests" / "data" / "scenario" / "robots" / "two_link.urdf"

# First iteration: exits at once (a finished, failed iteration). Later ones: write their pid,
# then sleep without connecting (the readiness timeout is far away).
CLIENT = """
import os, sys, time
marker = sys.argv[1]
if not os.path.exists(marker):
    open(marker, "w").close()
    sys.exit(3)
with open(marker + ".pid", "w") as f:
    f.write(str(os.getpid()))
time.sleep(600)  # allowed: a client that hangs (the runner must stop it)
"""


ARGS = ("--iterations", "4", "--workers", "1")


def _gone(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return True
    return stat[stat.rfind(")") + 2] in "ZX"


def _group_empty(pgid: int) -> bool:
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rfind(")") + 2 :].split()
        if int(fields[2]) == pgid and fields[0] not in "ZX":
            return False
    return True


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
@pytest.mark.slow
def test_signal_stops_the_run_and_writes_what_finished(tmp_path: Path, sig: int) -> None:
    client = tmp_path / "client.py"
    client.write_text(CLIENT)
    marker = tmp_path / "started"
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        yaml.safe_dump(
            {
                "robots": [{"robot": str(TWO_LINK)}],
                "environment": {"map": "empty"},
                "duration": 0.5,
                "clock": {"mode": "lockstep"},
                "client": {
                    "command": [sys.executable, str(client), str(marker)],
                    "readiness_timeout": 300,
                },
            }
        )
    )
    out = tmp_path / "out"
    run = subprocess.Popen(
        [sys.executable, "-m", "harness", "run", str(scenario), *ARGS, "--out", str(out)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group: the test can check that all of it is gone
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    pidfile = Path(str(marker) + ".pid")
    try:
        deadline = time.monotonic() + 120
        while not pidfile.exists() or not pidfile.read_text():
            assert run.poll() is None, run.communicate()
            assert time.monotonic() < deadline, "the second iteration's client never started"
            time.sleep(0.05)  # allowed: waiting for another process, no simulation here
        client_pid = int(pidfile.read_text())
        os.kill(run.pid, sig)
        _, stderr = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    assert run.returncode == 128 + sig, stderr
    assert f"interrupted by {signal.Signals(sig).name}" in stderr
    assert "Traceback" not in stderr
    results = json.loads((out / "results.json").read_text())
    text = json.dumps(results)
    assert "interrupted by" in text  # the running iteration, stopped
    assert "client exited with code 3" in text  # the one that finished
    assert "not run" not in text  # iterations 3 and 4 never started: not reported
    assert _gone(client_pid)
    deadline = time.monotonic() + 10
    while not _group_empty(run.pid) and time.monotonic() < deadline:
        time.sleep(0.05)  # allowed: waiting for processes to exit, no simulation here
    assert _group_empty(run.pid), "a worker process outlived harness run"
