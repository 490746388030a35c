"""Simulation tests of the pick-and-place controller, through the harness pytest plugin.

The controller runs as its own process (robot software) against this test's rosbridge URL;
the simulation is in lockstep and the controller advances it, so each run is identical and
is compared with the golden recording in ``recordings/test_pick_and_place/``. Update it after
an intended change with ``python -m pytest tests --harness-update-goldens``.
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.events import CollectingSink, CollisionBegin, JointLimitViolation
from harness.pytest_plugin import Golden
from harness.testing import connect

PROJECT = Path(__file__).resolve().parents[1]

# The box rests on the table: that contact is expected. Anything else (the arm touching the
# box, the table or itself) is not.
pytestmark = pytest.mark.harness(
    robot="demo", state_every=10, collisions={"ignore": [("box", "table")]}
)


def run_controller(url: str) -> dict[str, Any]:
    """Run the controller process against ``url``; its JSON result."""
    proc = subprocess.run(
        [sys.executable, "-m", "pick_and_place.controller", url],
        cwd=PROJECT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, f"controller failed ({proc.returncode}):\n{proc.stderr}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_reach_box_and_back(
    harness_session: Session, rosbridge_url: str, harness_events: CollectingSink, golden: Golden
) -> None:
    result = run_controller(rosbridge_url)

    assert result["home_error"] < 0.02
    assert result["max_tracking_error"] < 0.1
    assert harness_session.step_index == 2000  # 3.6 s of plan + 0.4 s settling, 2 ms steps
    golden.check(joint_position=1e-6, joint_velocity=1e-4, link_position=1e-6, link_rotation=1e-5)
    # The session has ended with golden.check(): every event is in.
    assert harness_events.of_kind(CollisionBegin) == []
    assert harness_events.of_kind(JointLimitViolation) == []


def test_joint_states_every_10_ms_of_sim_time(rosbridge_url: str) -> None:
    with connect(rosbridge_url) as client:
        states = client.subscribe("/joint_states", "sensor_msgs/msg/JointState")
        first = states.wait_for_message(sim_timeout=0.05)
        client.step(50)  # 0.1 s
    stamps = [m["header"]["stamp"]["nanosec"] for m in states.messages]
    assert first["header"]["stamp"]["nanosec"] == stamps[0]
    assert [b - a for a, b in itertools.pairwise(stamps)] == [10_000_000] * (len(stamps) - 1)
    assert len(stamps) == 11
