"""Fixtures of the resume tests: real recordings of real sessions, made once per worker, and
the helpers that feed a resumed session the parent's frames."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from harness import Session
from harness.recording import BridgeFrame, Recording
from harness.testing import connect

HERE = Path(__file__).resolve().parent
FJT = "control_msgs/action/FollowJointTrajectory"
ARM = "/joint_trajectory_controller/follow_joint_trajectory"
JOINTS = [f"joint{i}" for i in range(1, 8)]
TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5]
ARM_STEPS = 1000
ARM_CHUNK = 50  # the client steps in requests of this many steps
ARM_FORK = 300  # the goal (1 s = 500 steps) is in flight here


def load_helper(folder: str, name: str) -> ModuleType:
    """A helper module of another test folder, loaded by path (tests/<folder>/<name>.py)."""
    module_name = f"resume_tests_{folder}_{name}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, HERE.parent / folder / f"{name}.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


def goal(positions: list[float], seconds: float, tolerance: float = 0.01) -> dict[str, Any]:
    """A FollowJointTrajectory goal of the demo arm: one point at ``seconds``."""
    sec = int(seconds)
    return {
        "trajectory": {
            "joint_names": JOINTS,
            "points": [
                {
                    "positions": positions,
                    "time_from_start": {"sec": sec, "nanosec": round((seconds - sec) * 1e9)},
                }
            ],
        },
        "goal_tolerance": [
            {"name": j, "position": tolerance, "velocity": 0.0, "acceleration": 0.0} for j in JOINTS
        ],
        "goal_time_tolerance": {"sec": 1, "nanosec": 0},
    }


@pytest.fixture(scope="session")
def arm_parent(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The demo arm in lockstep, a real client sending a 1 s trajectory goal, then stepping
    in /harness/step requests of 50 steps to step 1000; recorded."""
    path = tmp_path_factory.mktemp("arm") / "parent.mcap"
    with (
        Session("demo", clock="lockstep", record_to=path) as session,
        connect(session.url) as client,
    ):
        handle = client.send_goal(ARM, FJT, goal(TARGET, 1.0))
        for _ in range(ARM_STEPS // ARM_CHUNK):
            client.step(ARM_CHUNK)
        assert handle.done
    return path


def incoming_after(path: Path, step: int) -> list[BridgeFrame]:
    """The parent's incoming frames and markers that took effect after ``step`` (recorded
    with ``step > step + 0``, i.e. at the boundary after it or later), without the
    ``harness/close`` marker a session records itself when it closes."""
    with Recording(path) as rec:
        return [
            f
            for f in rec.bridge_frames()
            if f.direction == 0 and f.step > step and f.topic != "harness/close"
        ]


def feed(session: Session, frames: list[BridgeFrame], last_step: int) -> None:
    """Apply ``frames`` to a live session's core at their recorded boundaries (stepping the
    session from Python in between), then step it to ``last_step``."""
    core = session.core
    for frame in frames:
        session.step(frame.step - 1 - session.step_index)
        session.call(
            lambda f=frame: core.replay_frame(f.connection, f.op, f.topic, f.payload)  # type: ignore[misc]
        )
    session.step(last_step - session.step_index)


def states(path: Path, start: int = 0) -> dict[int, bytes]:
    """Step -> the recorded physics state's bytes, from ``start`` on."""
    with Recording(path) as rec:
        return {
            s.step: np.asarray(s.state, dtype=np.float64).tobytes()
            for s in rec.physics_states(start)
        }


def frames_from(path: Path, start: int) -> list[tuple[Any, ...]]:
    """Every recorded bridge frame from step ``start`` on, as comparable tuples."""
    with Recording(path) as rec:
        return [
            (f.step, f.sim_time_ns, f.direction, f.connection, f.seq, f.op, f.topic, f.text,
             f.data)
            for f in rec.bridge_frames(start)
        ]  # fmt: skip


def messages_from(path: Path, start: int) -> dict[str, list[tuple[int, bytes]]]:
    """Topic -> every recorded message's (sim time, CDR bytes) from step ``start`` on."""
    with Recording(path) as rec:
        out: dict[str, list[tuple[int, bytes]]] = {}
        for topic in rec.topics:
            out[topic] = [
                (m.sim_time_ns, bytes(m.data)) for m in rec.messages(topic, start_step=start)
            ]
        return out
