"""Sans-I/O tests of the joint_trajectory_controller's interpolation, tolerances and goal
handling (no simulation, no sockets)."""

from __future__ import annotations

from typing import Any

import pytest

from harness.controllers import ControllerSpec, JointReadings
from harness.controllers.joint_trajectory import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    INVALID_JOINTS,
    OLD_HEADER_TIMESTAMP,
    PATH_TOLERANCE_VIOLATED,
    JointTrajectoryController,
)
from harness.controllers.spline import (
    Point,
    SampledTrajectory,
    SegmentTolerances,
    StateTolerance,
    goal_tolerances,
    interpolate,
    params_tolerances,
    within,
)

S = 1_000_000_000
PERIOD = 10_000_000


def test_linear_when_only_positions() -> None:
    a, b = Point(0, (0.0, 1.0)), Point(S, (2.0, -1.0))
    mid = interpolate(0, a, S, b, S // 4)
    assert mid.positions == pytest.approx((0.5, 0.5))
    assert mid.velocities == pytest.approx((2.0, -2.0))
    assert mid.accelerations == (0.0, 0.0)


def test_cubic_when_velocities_match_the_ends() -> None:
    a, b = Point(0, (0.0,), (1.0,)), Point(2 * S, (1.0,), (-0.5,))
    start = interpolate(0, a, 2 * S, b, 0)
    end = interpolate(0, a, 2 * S, b, 2 * S)
    assert start.positions[0] == pytest.approx(0.0)
    assert start.velocities[0] == pytest.approx(1.0)
    # at the end time the derivatives are dropped (the end state holds)
    assert end.positions[0] == pytest.approx(1.0)
    near = interpolate(0, a, 2 * S, b, 2 * S - 1000)
    assert near.velocities[0] == pytest.approx(-0.5, abs=1e-5)
    # a cubic, not linear: the midpoint differs from the chord's
    assert interpolate(0, a, 2 * S, b, S).positions[0] != pytest.approx(0.5)


def test_quintic_matches_positions_velocities_and_accelerations() -> None:
    a = Point(0, (0.0,), (0.0,), (2.0,))
    b = Point(S, (1.0,), (0.5,), (-1.0,))
    start = interpolate(0, a, S, b, 0)
    assert start.accelerations[0] == pytest.approx(2.0)
    near = interpolate(0, a, S, b, S - 10)
    assert near.positions[0] == pytest.approx(1.0, abs=1e-6)
    assert near.velocities[0] == pytest.approx(0.5, abs=1e-5)
    assert near.accelerations[0] == pytest.approx(-1.0, abs=1e-3)


def test_sampling_from_the_state_before_to_past_the_end() -> None:
    traj = SampledTrajectory((Point(S, (1.0,)), Point(2 * S, (3.0,))))
    traj.set_point_before(0, Point(0, (0.0,)))
    first, start, end = traj.sample(0)  # start stamp 0: starts at the first sample
    assert first is not None
    assert first.positions == (0.0,)
    assert (start, end) == (0, 0)
    half, _, _ = traj.sample(S // 2)
    assert half is not None
    assert half.positions[0] == pytest.approx(0.5)
    seg, start, end = traj.sample(S + S // 2)
    assert seg is not None
    assert seg.positions[0] == pytest.approx(2.0)
    assert (start, end) == (0, 1)
    last, start, end = traj.sample(5 * S)
    assert last is not None
    assert last.positions == (3.0,)
    assert end == 2


def test_tolerances_from_params_and_goal() -> None:
    defaults = params_tolerances(
        ["a", "b"],
        {
            "goal_time": 0.5,
            "stopped_velocity_tolerance": 0.02,
            "a": {"trajectory": 0.1, "goal": 0.01},
        },
    )
    assert defaults.goal_time == 0.5
    assert defaults.state[0] == StateTolerance(0.1)
    assert defaults.goal[0] == StateTolerance(0.01, 0.02)
    assert defaults.goal[1] == StateTolerance(0.0, 0.02)
    goal = {
        "path_tolerance": [{"name": "a", "position": -1.0, "velocity": 0.0, "acceleration": 0.0}],
        "goal_tolerance": [{"name": "b", "position": 0.2, "velocity": 0.0, "acceleration": 0.0}],
        "goal_time_tolerance": {"sec": 2, "nanosec": 0},
    }
    active = goal_tolerances(defaults, ["a", "b"], goal)
    assert active.state[0].position == 0.0  # -1 erases
    assert active.goal[1].position == 0.2
    assert active.goal_time == 2.0
    unknown = dict(goal, goal_tolerance=[{"name": "z", "position": 0.2}])
    kept = goal_tolerances(defaults, ["a", "b"], unknown)
    assert kept.state == defaults.state
    assert kept.notes
    illegal = dict(goal, goal_tolerance=[{"name": "b", "position": -3.0}])
    assert goal_tolerances(defaults, ["a", "b"], illegal).goal == defaults.goal


def test_within_ignores_zero_tolerances() -> None:
    assert within(StateTolerance(), 10.0, 10.0, 10.0)
    assert not within(StateTolerance(position=0.1), 0.2, 0.0, 0.0)
    assert not within(StateTolerance(velocity=0.1), 0.0, -0.2, 0.0)
    assert within(StateTolerance(position=0.1, velocity=0.1), 0.05, 0.05, 0.0)
    assert isinstance(params_tolerances([], {}), SegmentTolerances)


# ------------------------------------------------------------------ the controller, sans-I/O

JOINTS = ("a", "b")


def _jtc(**params: Any) -> JointTrajectoryController:
    spec = ControllerSpec("arm", "joint_trajectory_controller/JointTrajectoryController",
                          {"joints": list(JOINTS), **params})  # fmt: skip
    jtc = JointTrajectoryController(spec, "test", {"a": "position", "b": "position"})
    jtc.activate(_state(0, 0.0, 0.0))
    return jtc


def _state(t: int, a: float, b: float) -> JointReadings:
    return JointReadings(t, {"a": a, "b": b}, {"a": 0.0, "b": 0.0}, {"a": 0.0, "b": 0.0})


def _goal(points: list[tuple[float, list[float]]], stamp: int = 0, **extra: Any) -> dict[str, Any]:
    return {
        "trajectory": {
            "header": {"stamp": {"sec": stamp // S, "nanosec": stamp % S}, "frame_id": ""},
            "joint_names": list(JOINTS),
            "points": [
                {"positions": p, "time_from_start": {"sec": int(t), "nanosec": round(t % 1 * 1e9)}}
                for t, p in points
            ],
        },
        **extra,
    }


@pytest.mark.parametrize(
    ("goal", "code"),
    [
        ({"trajectory": {**_goal([(1, [0, 0])])["trajectory"], "joint_names": ["a", "x"]}},
         INVALID_JOINTS),
        ({"trajectory": {**_goal([(1, [0, 0])])["trajectory"], "joint_names": ["a"]}},
         INVALID_JOINTS),
        (_goal([(1, [0, 0]), (1, [1, 1])]), INVALID_GOAL),
        (_goal([(1, [0])]), INVALID_GOAL),
        (_goal([]), INVALID_GOAL),
        (_goal([(0.1, [0, 0])], stamp=S // 10), OLD_HEADER_TIMESTAMP),
    ],
)  # fmt: skip
def test_invalid_goals_abort_with_error_codes(goal: dict[str, Any], code: int) -> None:
    jtc = _jtc()
    out = jtc.on_goal("~/follow_joint_trajectory", 7, goal, _state(S, 0.0, 0.0))
    assert [(r.goal, r.status, r.values["error_code"]) for r in out.results] == [(7, 6, code)]
    assert jtc.goal is None
    assert not out.commands


def _run(jtc: JointTrajectoryController, until: int, follow: float = 1.0) -> list[Any]:
    """Updates every PERIOD; the joints reach ``follow`` of the last command each cycle."""
    results = []
    pos = {"a": 0.0, "b": 0.0}
    t = 0
    while t <= until and jtc.goal is not None:
        out = jtc.update(_state(t, pos["a"], pos["b"]), PERIOD)
        for c in out.commands:
            assert c.position is not None
            pos[c.joint] += follow * (c.position - pos[c.joint])
        results += out.results
        t += PERIOD
    return results


def test_goal_succeeds_and_sends_feedback_at_the_monitor_rate() -> None:
    jtc = _jtc()
    jtc.on_goal("g", 1, _goal([(0.5, [0.5, -0.5])]), _state(0, 0.0, 0.0))
    feedback = 0
    states = 0
    pos = [0.0, 0.0]
    t = 0
    results: list[Any] = []
    while jtc.goal is not None and t < 2 * S:
        out = jtc.update(_state(t, *pos), PERIOD)
        feedback += len(out.feedback)
        for c in out.commands:
            pos[JOINTS.index(c.joint)] = c.position or 0.0
        results += out.results
        states += len([p for p in out.publications if p.topic == "~/controller_state"])
        t += PERIOD
    assert [(r.status, r.values["error_code"]) for r in results] == [(4, 0)]
    assert pos == pytest.approx([0.5, -0.5])
    assert 9 <= feedback <= 12  # 20 Hz over ~0.5 s
    assert 24 <= states <= 28  # state_publish_rate 50 Hz


def test_path_tolerance_violation_aborts_and_holds() -> None:
    jtc = _jtc(constraints={"a": {"trajectory": 0.01}})
    jtc.on_goal("g", 1, _goal([(0.5, [0.5, 0.0])]), _state(0, 0.0, 0.0))
    results = _run(jtc, S, follow=0.0)  # the joints never move
    assert [(r.status, r.values["error_code"]) for r in results] == [(6, PATH_TOLERANCE_VIOLATED)]


def test_goal_time_tolerance_exceeded_aborts() -> None:
    jtc = _jtc(constraints={"goal_time": 0.1, "a": {"goal": 0.001}})
    jtc.on_goal("g", 1, _goal([(0.2, [0.5, 0.0])]), _state(0, 0.0, 0.0))
    results = _run(jtc, 2 * S, follow=0.05)  # lags: outside the goal tolerance at the end
    assert [(r.status, r.values["error_code"]) for r in results] == [(6, GOAL_TOLERANCE_VIOLATED)]


def test_new_goal_preempts_and_cancel_holds() -> None:
    jtc = _jtc()
    jtc.on_goal("g", 1, _goal([(1, [0.5, 0.0])]), _state(0, 0.0, 0.0))
    out = jtc.on_goal("g", 2, _goal([(1, [0.1, 0.0])]), _state(PERIOD, 0.0, 0.0))
    assert [(r.goal, r.status, r.values["error_code"]) for r in out.results] == [(1, 6, -1)]
    out = jtc.on_cancel("g", 2, _state(2 * PERIOD, 0.01, 0.0))
    assert [(r.goal, r.status) for r in out.results] == [(2, 5)]
    assert [(c.joint, c.position) for c in out.commands] == [("a", 0.01), ("b", 0.0)]
    assert jtc.goal is None
    assert jtc.trajectory is None
