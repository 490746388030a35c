"""Resume with ROS 2: fork equivalence of a DDS-driven run (an rclpy node stepping the demo arm
through the gateway in lockstep; its connection a ghost peer after the fork), and a resumed
session driven by a new rclpy node over DDS. Skipped, saying why, without the ROS 2 venv."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness import Session
from harness.cli import main
from harness.recording import Recording
from harness.ros2 import Ros2Install, Ros2Unavailable, find_ros2
from harness.ros2.testing import run_node

from .conftest import feed, frames_from, incoming_after, states

ROOT = Path(__file__).resolve().parents[2]
ARM_NODE = ROOT / "examples" / "ros2_node" / "arm_node.py"
FORK = 250  # inside the node's 0.5 s trajectory; the node steps 5 steps per request
STEPS = 500


@pytest.fixture(scope="module")
def ros2() -> Ros2Install:
    try:
        return find_ros2()
    except Ros2Unavailable as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def dds_run(ros2: Ros2Install, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("dds") / "dds.mcap"
    with Session("demo", ros2=True, record_to=path) as session:
        result = run_node(ros2, session.ros_domain_id or 0, ARM_NODE, ["--lockstep"])
        assert result["joint1"] == pytest.approx(0.3, abs=0.01)
    return path


@pytest.mark.slow
def test_a_dds_driven_run_resumed_and_fed_its_frames_is_the_same_run(
    dds_run: Path, tmp_path: Path
) -> None:
    with Recording(dds_run) as rec:
        last = rec.last_step
        dds = [f for f in rec.bridge_frames() if f.direction == 0 and f.connection == 1]
    assert last == STEPS
    assert any(f.topic == "/joint_trajectory" for f in dds)
    child = tmp_path / "child.mcap"
    with Session.resume(dds_run, step=FORK, record_to=child) as session:
        assert session.core.bridge is not None
        assert 1 in session.core.bridge.connections  # the gateway's link: a ghost peer
        feed(session, incoming_after(dds_run, FORK), last)
    assert states(child, FORK) == states(dds_run, FORK)
    assert frames_from(child, FORK) == frames_from(dds_run, FORK)
    assert main(["replay", str(child), "--level", "full"]) == 0


@pytest.mark.slow
def test_an_rclpy_node_drives_a_resumed_session(
    ros2: Ros2Install, dds_run: Path, tmp_path: Path
) -> None:
    child = tmp_path / "rclpy.mcap"
    with Session.resume(dds_run, step=FORK, record_to=child, ros2=True) as session:
        assert session.ros_domain_id is not None
        result = run_node(
            ros2, session.ros_domain_id, ARM_NODE, ["--lockstep", "--target", "-0.2",
                                                    "--sim-seconds", "1.0"],
        )  # fmt: skip
        reached = session.step_index
    assert reached == FORK + 500  # the node stepped the resumed run 1 s on from the fork
    assert result["joint1"] == pytest.approx(-0.2, abs=0.01)
    assert result["stamp_ns"] >= (FORK + 500) * 2_000_000
    with Recording(child) as rec:
        live = {f.connection for f in rec.bridge_frames(FORK) if f.direction == 0}
    assert 2 in live  # the new gateway connected after the ghost
    assert main(["replay", str(child), "--level", "full"]) == 0
