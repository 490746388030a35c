"""End to end with roslibpy (PyPI 2.1, in a subprocess): the demo arm follows a
/joint_trajectory in lockstep driven by /harness/step; two runs give identical /joint_states
streams, every field of every message."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from harness.models import LoadedRobot
from harness.session import Session

SCRIPT = Path(__file__).with_name("roslibpy_trajectory.py")


def _run(robot: LoadedRobot) -> dict[str, Any]:
    with Session(robot) as session:
        port = session.url.rsplit(":", 1)[1]
        proc = subprocess.run(
            [sys.executable, str(SCRIPT), port], capture_output=True, text=True, timeout=60
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert proc.stdout.splitlines()[-1] == "OK", proc.stdout
        assert session.step_index == 500
    result: dict[str, Any] = json.loads(proc.stdout.splitlines()[0])
    return result


@pytest.mark.slow
def test_trajectory_in_lockstep_is_identical_across_runs(demo_position: LoadedRobot) -> None:
    first, second = _run(demo_position), _run(demo_position)
    states = first["states"]
    assert len(states) == 100  # 1 s of sim time at 100 Hz (step 0 was before the subscription)
    assert first["last_answer"] == {"sim_time": {"sec": 1, "nanosec": 0}}
    stamps = [s["header"]["stamp"]["sec"] * 10**9 + s["header"]["stamp"]["nanosec"] for s in states]
    assert stamps == [10_000_000 * (i + 1) for i in range(100)]
    # the arm went along: past the first point's joint1 region, ending near the last point
    joint1 = [s["position"][0] for s in states]
    assert max(joint1) > 0.4
    final = states[-1]["position"]
    assert abs(final[0] - -0.2) < 0.02
    assert abs(final[1] - -0.6) < 0.02
    assert abs(final[3] - -1.6) < 0.02
    assert first == second
