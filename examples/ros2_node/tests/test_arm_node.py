"""The robot project's tests of its ROS 2 node (arm_node.py), as a project would write them:
the simulation on DDS (``ros2=True``), and the same node through a real rosbridge server with
the simulation connected to it as a client (``connect=``). Both need ROS 2 (`make ros2` in
the harness, or a sourced install): they skip, saying why, without it."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from harness import Session
from harness.replay import verify
from harness.ros2 import Ros2Install, Ros2Unavailable, choose_domain_id, find_ros2
from harness.ros2.testing import rosbridge_server, run_node

NODE = Path(__file__).resolve().parents[1] / "arm_node.py"


@pytest.fixture(scope="session")
def ros2() -> Ros2Install:
    try:
        return find_ros2()
    except Ros2Unavailable as exc:
        pytest.skip(str(exc))


@pytest.fixture
def rosbridge(ros2: Ros2Install) -> Iterator[tuple[str, int]]:
    """rosbridge-server-rs on a private domain: (URL, domain id)."""
    domain = choose_domain_id()
    try:
        with rosbridge_server(ros2, domain) as url:
            yield url, domain
    except Ros2Unavailable as exc:
        pytest.skip(str(exc))


def check(result: dict, session: Session) -> None:
    assert result["joint1"] == pytest.approx(0.3, abs=0.01)
    assert result["stamp_ns"] == result["clock_ns"] == 1_000_000_000  # its clock is sim time
    assert result["description_bytes"] > 1000  # the late subscriber got the latched URDF
    assert session.joint_positions()[0] == pytest.approx(0.3, abs=0.01)


@pytest.mark.harness(ros2=True)
def test_node_on_dds_steps_the_simulation(
    harness_session: Session, ros_domain_id: int, ros2: Ros2Install
) -> None:
    result = run_node(ros2, ros_domain_id, NODE, ["--lockstep"])
    assert result["step_answer_ns"] == 1_000_000_000
    assert harness_session.step_index == 500
    check(result, harness_session)


def test_node_through_a_rosbridge_server(
    rosbridge: tuple[str, int],
    ros2: Ros2Install,
    harness_session_factory: Callable[..., Session],
    harness_recording: Path,
) -> None:
    url, domain = rosbridge
    session = harness_session_factory(connect=url)  # the marker's connect= as a keyword
    result = run_node(ros2, domain, NODE, ["--lockstep"])
    assert session.step_index == 500
    check(result, session)
    session.close()
    assert verify(harness_recording).reproduced  # (its loggers publish on /rosout: physics level)
