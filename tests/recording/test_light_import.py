"""Reading a recording loads neither MuJoCo nor the simulation nor the session (issue 32).

A subprocess installs a meta-path finder that refuses ``mujoco``, ``harness.sim`` and
``harness.session`` (any of their submodules too), then reads a real recording through
:mod:`harness.recording` and runs ``harness inspect`` on it: any import of those fails loudly.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "recordings" / "scenarios" / "demo.mcap"

READER = r"""
import sys

BLOCKED = ("mujoco", "harness.sim", "harness.session")


class Refuse:
    def find_spec(self, name, path=None, target=None):
        if any(name == b or name.startswith(b + ".") for b in BLOCKED):
            raise ImportError(f"blocked import of {name}")
        return None


sys.meta_path.insert(0, Refuse())

import harness.recording
from harness.recording import AppliedInput, Recording

path = sys.argv[1]
with Recording(path) as rec:
    assert rec.message_count > 0
    counts = {}
    for m in rec.messages():
        counts[m.topic] = counts.get(m.topic, 0) + 1
    assert sum(counts.values()) == rec.message_count, (counts, rec.message_count)
    names = rec.attachment_names
    assert names and all(rec.attachment(n) for n in names)
    assert rec.all_metadata
    inputs = list(rec.applied_inputs())
    assert inputs and all(isinstance(i, AppliedInput) for i in inputs)
    arrays = rec.physics_state_arrays()
    assert len(arrays.steps) > 0 and arrays.state.shape[0] == len(arrays.steps)
    rec.epochs()

from harness.cli import main

code = main(["inspect", path])
assert code == 0, code
loaded = sorted(m for m in sys.modules if m.split(".")[0] == "mujoco" or m.startswith(BLOCKED))
assert not loaded, loaded
print("READ-OK")
"""


def test_reading_and_inspecting_a_recording_never_import_mujoco_sim_or_session() -> None:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    done = subprocess.run(
        [sys.executable, "-c", READER, str(DEMO)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "READ-OK" in done.stdout
