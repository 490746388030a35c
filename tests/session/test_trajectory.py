"""Trajectory acceptance and interpolation (sans-I/O, on a real Simulation)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.controllers.command_topics import parse_trajectory
from harness.models import LoadedRobot
from harness.session import CommandRefused
from harness.sim import Simulation


def _msg(points: list[tuple[list[float], int]], stamp_ns: int = 0) -> dict[str, object]:
    return {
        "header": {"stamp": {"sec": stamp_ns // 10**9, "nanosec": stamp_ns % 10**9}},
        "joint_names": ["joint1", "joint2"],
        "points": [
            {"positions": p, "time_from_start": {"sec": t // 10**9, "nanosec": t % 10**9}}
            for p, t in points
        ],
    }


def test_linear_in_position_from_the_current_command(demo_position: LoadedRobot) -> None:
    sim = Simulation(demo_position)
    start = sim.joint_commands()[:2]
    trajectory = parse_trajectory(
        sim, _msg([([0.2, -0.5], 1_000_000_000), ([0.4, -0.1], 3_000_000_000)]), 10_000_000
    )
    assert trajectory.times_ns == (10_000_000, 1_010_000_000, 3_010_000_000)
    position, velocity = trajectory.setpoint(510_000_000)  # half-way along the first segment
    np.testing.assert_allclose(position, (start + np.array([0.2, -0.5])) / 2, atol=1e-15)
    np.testing.assert_allclose(velocity, np.array([0.2, -0.5]) - start, atol=1e-12)
    position, velocity = trajectory.setpoint(2_010_000_000)
    np.testing.assert_allclose(position, [0.3, -0.3], atol=1e-15)
    np.testing.assert_allclose(velocity, [0.1, 0.2], atol=1e-12)
    position, velocity = trajectory.setpoint(9_000_000_000)  # after the end: hold
    np.testing.assert_array_equal(position, [0.4, -0.1])
    np.testing.assert_array_equal(velocity, [0.0, 0.0])
    assert trajectory.without({"joint1"}).joints == ("joint2",)  # type: ignore[union-attr]
    assert trajectory.without({"joint1", "joint2"}) is None


def test_header_stamp_sets_the_start(demo_position: LoadedRobot) -> None:
    sim = Simulation(demo_position)
    trajectory = parse_trajectory(sim, _msg([([0.1, 0.1], 0)], stamp_ns=5 * 10**9), 0)
    assert trajectory.times_ns == (5 * 10**9,)
    np.testing.assert_array_equal(trajectory.setpoint(0)[0], [0.1, 0.1])


@pytest.mark.parametrize(
    ("points", "reason"),
    [
        ([], "trajectory has no points"),
        (
            [([0.1, 0.1], 2_000_000_000), ([0.2, 0.2], 1_000_000_000)],
            "point 1: time_from_start 1 s must be >= 0 and after the previous point's",
        ),
    ],
)
def test_refused(
    demo_position: LoadedRobot, points: list[tuple[list[float], int]], reason: str
) -> None:
    with pytest.raises(CommandRefused) as info:
        parse_trajectory(Simulation(demo_position), _msg(points), 0)
    assert str(info.value) == reason


def test_effort_joints_cannot_follow_a_trajectory() -> None:
    from harness.models import load_robot

    sim = Simulation(load_robot("demo", control={"joint1": "effort"}))
    with pytest.raises(CommandRefused, match="joint 'joint1' is effort-controlled"):
        parse_trajectory(sim, _msg([([0.1, 0.1], 10**9)]), 0)
