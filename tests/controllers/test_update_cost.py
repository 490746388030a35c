"""The joint_trajectory_controller's per-update shortcuts (issue 36's speed) give what the plain
computation gave: joints taken from the readings' array (:class:`harness.controllers.values.
JointIndex`) as from one look per joint, ``~/controller_state`` built only when published,
feedback built only when it goes out. Sans-I/O: a scripted plant follows the commands; every
output of every call is compared, and pinned to what the controller gave before the shortcuts
(a digest of the whole transcript)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.controllers import (
    NOTHING,
    Command,
    ControllerOutput,
    ControllerSpec,
    JointReadings,
    make_controller,
)
from harness.controllers import joint_trajectory as jtc_module
from harness.controllers.forward_command import ForwardCommandController
from harness.controllers.gripper_action import GripperActionController
from harness.controllers.joint_trajectory import JointTrajectoryController
from harness.controllers.spline import Point, Sample, interpolate
from harness.controllers.values import JointIndex
from harness.session.core.readings import Snapshot

S = 1_000_000_000
PERIOD = 10_000_000
ROBOT = ("base", "a", "b", "c", "finger")  # the robot's joints; the controller's are a, b, c
JOINTS = ("a", "b", "c")
TYPE = "joint_trajectory_controller/JointTrajectoryController"
FJT = "~/follow_joint_trajectory"


class Refusing(Mapping[str, float]):
    """Readings that give their array only: any look by name fails the test."""

    def __init__(self, names: Sequence[str], values: Sequence[float]) -> None:
        self.names = tuple(names)
        self._array = np.array(values, dtype=np.float64)

    def array(self) -> npt.NDArray[np.float64]:
        return self._array

    def __getitem__(self, key: str) -> float:
        raise AssertionError(f"looked up {key!r} one by one")

    def __iter__(self) -> Iterator[str]:
        raise AssertionError("iterated")

    def __len__(self) -> int:
        return len(self.names)


# ------------------------------------------------------------------ a scripted plant


class Plant:
    """The robot's joints: each commanded joint moves ``follow`` of the way to its command per
    update (velocity: the move over the period); ``make`` turns arrays into readings."""

    def __init__(self, make: Callable[[Sequence[str], list[float]], Mapping[str, float]]) -> None:
        self.make = make
        self.pos = [0.05 * i - 0.1 for i in range(len(ROBOT))]
        self.vel = [0.0] * len(ROBOT)
        self.follow = 1.0

    def readings(self, t: int) -> JointReadings:
        return JointReadings(
            t,
            self.make(ROBOT, list(self.pos)),
            self.make(ROBOT, list(self.vel)),
            self.make(ROBOT, [0.0] * len(ROBOT)),
        )

    def apply(self, out: ControllerOutput) -> None:
        for c in out.commands:
            i = ROBOT.index(c.joint)
            assert c.position is not None
            step = self.follow * (c.position - self.pos[i])
            self.pos[i] += step
            self.vel[i] = step / (PERIOD / S)


def _dict(names: Sequence[str], values: list[float]) -> Mapping[str, float]:
    return dict(zip(names, values, strict=True))


def _snapshot(names: Sequence[str], values: list[float]) -> Mapping[str, float]:
    return Snapshot(names, lambda: np.array(values, dtype=np.float64))


def _record(out: ControllerOutput) -> list[Any]:
    return [
        [[c.joint, c.position, c.velocity, c.effort] for c in out.commands],
        [[p.topic, p.type, p.msg] for p in out.publications],
        [[f.goal, f.values] for f in out.feedback],
        [[r.goal, r.values, r.status] for r in out.results],
        [[log.level, log.text, log.connection] for log in out.logs],
    ]


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // S, "nanosec": ns % S}


def _trajectory(points: list[dict[str, Any]], joints: Sequence[str] = JOINTS) -> dict[str, Any]:
    return {
        "header": {"stamp": _stamp(0), "frame_id": ""},
        "joint_names": list(joints),
        "points": [{**p, "time_from_start": _stamp(round(p["t"] * S))} for p in points],
    }


def _p(t: float, positions: list[float], **fields: list[float]) -> dict[str, Any]:
    return {"t": t, "positions": positions, **fields}


def transcript(
    make: Callable[[Sequence[str], list[float]], Mapping[str, float]],
    params: Mapping[str, Any],
) -> list[Any]:
    """Every output of a controller over ``params`` through holding, a topic trajectory,
    goals that succeed, are preempted, canceled, and abort on path and goal-time tolerances."""
    spec = ControllerSpec("arm", TYPE, {"joints": list(JOINTS), **params})
    jtc = JointTrajectoryController(spec, "test", {j: "position" for j in ROBOT})
    plant = Plant(make)
    log: list[Any] = []
    t = 0

    def call(what: str, out: ControllerOutput) -> None:
        plant.apply(out)
        log.append([what, t, _record(out)])

    def run(updates: int) -> None:
        nonlocal t
        for _ in range(updates):
            call("update", jtc.update(plant.readings(t), PERIOD))
            t += PERIOD

    call("activate", jtc.activate(plant.readings(t)))
    run(7)  # holding
    topic = _trajectory([_p(0.2, [0.3, -0.2, 0.1]), _p(0.4, [0.1, 0.0, 0.2])])
    call("message", jtc.on_message("~/joint_trajectory", topic, 0, plant.readings(t)))
    plant.follow = 0.5
    run(50)
    quintic = [
        _p(0.3, [0.4, 0.1, -0.3], velocities=[0.2, 0.1, 0.0], accelerations=[0.0, 0.1, 0.0]),
        _p(0.7, [0.2, 0.3, -0.1], velocities=[0.0, 0.0, 0.0], accelerations=[0.0, 0.0, 0.0]),
    ]
    goal = {
        "trajectory": _trajectory(quintic),
        "goal_tolerance": [{"name": "a", "position": 0.01, "velocity": 0.5, "acceleration": 0}],
        "path_tolerance": [{"name": "b", "position": 0.5, "velocity": 0, "acceleration": 0}],
    }
    plant.follow = 1.0
    call("goal 1", jtc.on_goal(FJT, 1, goal, plant.readings(t)))
    run(90)  # succeeds
    cubic = [_p(0.5, [0.0, 0.0, 0.0], velocities=[0.0, 0.0, 0.0])]
    call("goal 2", jtc.on_goal(FJT, 2, {"trajectory": _trajectory(cubic)}, plant.readings(t)))
    run(12)
    call("goal 3", jtc.on_goal(FJT, 3, {"trajectory": _trajectory(quintic)}, plant.readings(t)))
    run(9)
    call("cancel 3", jtc.on_cancel(FJT, 3, plant.readings(t)))
    run(5)
    plant.follow = 0.0  # stuck: the path tolerance of b aborts
    tight = {**goal, "path_tolerance": [{"name": "b", "position": 0.05}]}
    call("goal 4", jtc.on_goal(FJT, 4, tight, plant.readings(t)))
    run(40)
    plant.follow = 0.05  # lags: past goal_time outside the goal tolerance
    late = {
        "trajectory": _trajectory([_p(0.2, [0.5, 0.1, 0.0])]),
        "goal_tolerance": [{"name": "a", "position": 0.001}],
        "goal_time_tolerance": _stamp(S // 10),
    }
    call("goal 5", jtc.on_goal(FJT, 5, late, plant.readings(t)))
    run(60)
    plant.follow = 0.8
    partial = _trajectory([_p(0.3, [0.2])], joints=["b"])
    call("goal 6", jtc.on_goal(FJT, 6, {"trajectory": partial}, plant.readings(t)))
    run(45)
    call("deactivate", jtc.deactivate(plant.readings(t)))
    return log


def digest(log: list[Any]) -> str:
    """The transcript's SHA-256 (floats by ``repr``: every bit counts)."""
    return hashlib.sha256(json.dumps(log, sort_keys=True).encode()).hexdigest()


PARAMS: dict[str, dict[str, Any]] = {
    "default": {},
    "velocity command": {"command_interfaces": ["position", "velocity"]},
    "position state only": {
        "state_interfaces": ["position"],
        "allow_partial_joints_goal": True,
        "state_publish_rate": 0.0,
        "action_monitor_rate": 33.0,
    },
    "constraints": {
        "allow_partial_joints_goal": True,
        "constraints": {
            "goal_time": 0.3,
            "stopped_velocity_tolerance": 0.0,
            "a": {"goal": 0.02},
            "c": {"trajectory": 0.4},
        },
    },
    "no tolerances": {"constraints": {"stopped_velocity_tolerance": 0.0}},
}
PINNED = {
    # the transcripts of the controller before the shortcuts (main at 16c044b)
    "constraints": "730a8368a7fc8a25e5377d9c1fdda2e55a37a824b1dcd1c9750a31405b2610d6",
    "default": "5bb9a81fd0fc24c65f4e2e2db6c031ba81b4acb8d2fdc36cf433ac21df491412",
    "no tolerances": "5bb9a81fd0fc24c65f4e2e2db6c031ba81b4acb8d2fdc36cf433ac21df491412",
    "position state only": "da02a35d281417fdff2e1555f31daac688e1a06759ebb14855e1122a51967c3c",
    "velocity command": "3f714be5f694e84a3fa2d2273dbb0159dd38564157215903af84a06b11444da6",
}


@pytest.mark.parametrize("case", sorted(PARAMS))
def test_outputs_are_what_they_were_bit_for_bit(case: str) -> None:
    by_dict = transcript(_dict, PARAMS[case])
    by_array = transcript(_snapshot, PARAMS[case])
    assert json.dumps(by_array) == json.dumps(by_dict)
    assert digest(by_array) == PINNED[case]


# ------------------------------------------------------------------ the shortcuts' mechanisms


def _controller(**params: Any) -> JointTrajectoryController:
    spec = ControllerSpec("arm", TYPE, {"joints": list(JOINTS), **params})
    return JointTrajectoryController(spec, "test", {j: "position" for j in ROBOT})


def _refusing(t: int, positions: Sequence[float]) -> JointReadings:
    velocities = [0.1 * i for i in range(len(ROBOT))]
    zeros = [0.0] * len(ROBOT)
    return JointReadings(
        t, Refusing(ROBOT, positions), Refusing(ROBOT, velocities), Refusing(ROBOT, zeros)
    )


def test_joints_are_taken_from_the_array_without_a_look_per_joint() -> None:
    jtc = _controller()
    positions = [9.0, 0.1, 0.2, 0.3, 9.0]
    out = jtc.activate(_refusing(0, positions))
    assert jtc.holding is not None
    assert jtc.holding.positions == (0.1, 0.2, 0.3)
    out = jtc.update(_refusing(PERIOD, positions), PERIOD)
    assert out.publications[0].msg["feedback"]["velocities"] == pytest.approx([0.1, 0.2, 0.3])
    goal = {"trajectory": _trajectory([_p(0.1, [0.2, 0.2, 0.2])])}
    out = jtc.on_goal(FJT, 1, goal, _refusing(PERIOD, positions))
    assert not out.results
    out = jtc.update(_refusing(2 * PERIOD, positions), PERIOD)
    assert [c.joint for c in out.commands] == list(JOINTS)
    assert out.commands[0].position == pytest.approx(0.1 + 0.1 * 0.1)
    out = jtc.on_cancel(FJT, 1, _refusing(3 * PERIOD, [9.0, 0.4, 0.5, 0.6, 9.0]))
    assert [(c.joint, c.position) for c in out.commands] == [
        ("a", 0.4),
        ("b", 0.5),
        ("c", 0.6),
    ]


def _plain(t: int, positions: Sequence[float]) -> JointReadings:
    return Plant(_dict).readings(t)._replace(position=_dict(ROBOT, list(positions)))


def _count_point_msgs(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls = [0]
    plain = jtc_module.point_msg

    def counted(*args: Any, **kwargs: Any) -> dict[str, Any]:
        calls[0] += 1
        return plain(*args, **kwargs)

    monkeypatch.setattr(jtc_module, "point_msg", counted)
    return calls


def test_the_state_message_is_built_only_when_asked_for(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _count_point_msgs(monkeypatch)
    jtc = _controller()
    jtc.activate(_plain(0, [0.0, 0.1, 0.2, 0.3, 0.0]))
    out = jtc.update(_plain(0, [0.0, 0.1, 0.25, 0.3, 0.0]), PERIOD)
    [publication] = out.publications
    assert publication.topic == "~/controller_state"
    assert calls[0] == 0  # published to no one: never built
    msg = publication.msg
    assert calls[0] == 3  # feedback (= actual), reference (= output, desired), error
    assert msg["error"]["positions"] == pytest.approx([0.0, -0.05, 0.0])
    assert publication.msg is msg


def test_feedback_is_built_only_when_it_goes_out(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _count_point_msgs(monkeypatch)
    jtc = _controller(action_monitor_rate=20.0)
    jtc.activate(_plain(0, [0.0] * len(ROBOT)))
    goal = {"trajectory": _trajectory([_p(1.0, [0.2, 0.2, 0.2])])}
    jtc.on_goal(FJT, 1, goal, _plain(0, [0.0] * len(ROBOT)))
    sent = 0
    for k in range(1, 31):  # 0.3 s at 100 Hz: feedback at 20 Hz
        out = jtc.update(_plain(k * PERIOD, [0.0] * len(ROBOT)), PERIOD)
        sent += len(out.feedback)
    assert sent == 6
    assert calls[0] == 3 * sent  # desired, actual, error of each sent; none per update


# ------------------------------------------------------------------ JointIndex


@settings(max_examples=60, deadline=None)
@given(
    names=st.lists(st.sampled_from("abcdefgh"), min_size=1, max_size=8, unique=True),
    data=st.data(),
)
def test_joint_index_takes_what_one_look_per_joint_takes(names: list[str], data: Any) -> None:
    joints = data.draw(st.lists(st.sampled_from(names), min_size=1, unique=True))
    values = data.draw(
        st.lists(st.floats(allow_nan=False), min_size=len(names), max_size=len(names))
    )
    index = JointIndex(joints)
    plain = dict(zip(names, values, strict=True))
    snapshot = Snapshot(tuple(names), lambda: np.array(values, dtype=np.float64))
    expected = [plain[j] for j in joints]
    for _ in range(2):  # the kept index as the fresh one
        got = index.take(snapshot)
        assert json.dumps(got) == json.dumps(expected)  # bit for bit, -0.0 included
        assert index.take(plain) == expected


def test_joint_index_follows_the_names_and_refuses_an_unknown_joint() -> None:
    index = JointIndex(("b", "a"))
    first = Snapshot(("a", "b", "c"), lambda: np.array([1.0, 2.0, 3.0]))
    assert index.take(first) == [2.0, 1.0]
    other = Snapshot(("b", "x", "a"), lambda: np.array([4.0, 5.0, 6.0]))
    assert index.take(other) == [4.0, 6.0]
    lacking = Snapshot(("a", "c"), lambda: np.array([1.0, 3.0]))
    with pytest.raises(KeyError, match="'b'"):
        index.take(lacking)


# ------------------------------------------------------------------ an idle update's output


def test_an_idle_update_gives_the_one_shared_output_which_refuses_changes() -> None:
    forward = make_controller(
        ControllerSpec("fwd", "forward_command_controller/ForwardCommandController",
                       {"joints": list(JOINTS), "interface_name": "position"}),
        "test", {j: "position" for j in ROBOT}, ROBOT,
    )  # fmt: skip
    gripper = make_controller(
        ControllerSpec("grip", "position_controllers/GripperActionController", {"joint": "a"}),
        "test", {j: "position" for j in ROBOT}, ROBOT,
    )  # fmt: skip
    assert isinstance(forward, ForwardCommandController)
    assert isinstance(gripper, GripperActionController)
    state = Plant(_dict).readings(0)
    gripper.activate(state)
    for controller in (forward, gripper):
        out = controller.update(state, PERIOD)
        assert out is NOTHING
    assert ControllerOutput() == NOTHING  # it says it is empty (it is a subclass: both ways)
    assert ControllerOutput(where="x") != NOTHING
    with pytest.raises(AttributeError):
        NOTHING.commands.append(Command("a", 1.0))
    with pytest.raises((AttributeError, TypeError)):
        NOTHING.commands += [Command("a", 1.0)]
    with pytest.raises(AttributeError, match="shared"):
        NOTHING.where = "x"
    mine = ControllerOutput(commands=[Command("a", 1.0)])
    mine.extend(NOTHING)
    assert mine == ControllerOutput(commands=[Command("a", 1.0)])
    assert not NOTHING.commands
    assert NOTHING.where == ""


# ------------------------------------------------------------------ interpolation


def _reference_interpolate(t_a: int, a: Point, t_b: int, b: Point, t: int) -> Sample:
    """:func:`interpolate` as it was written before its per-joint locals (verbatim)."""
    dim = len(a.positions)
    so_far = (t - t_a) / 1e9
    between = (t_b - t_a) / 1e9
    has_vel = bool(a.velocities) and bool(b.velocities)
    has_acc = bool(a.accelerations) and bool(b.accelerations)
    has_eff = bool(a.effort) and bool(b.effort)
    if so_far < 0.0:
        so_far = 0.0
        has_vel = has_acc = False
    if so_far > between:
        so_far = between
        has_vel = has_acc = False
    ts = [1.0]
    for _ in range(5):
        ts.append(ts[-1] * so_far)
    pos = [0.0] * dim
    vel = [0.0] * dim
    acc = [0.0] * dim
    eff = [0.0] * dim
    if has_eff:
        for i in range(dim):
            slope = (b.effort[i] - a.effort[i]) / between if between != 0.0 else 0.0
            eff[i] = a.effort[i] + ts[1] * slope
    if has_vel and has_acc:
        T = [1.0]
        for _ in range(5):
            T.append(T[-1] * between)
        for i in range(dim):
            p0, v0, a0 = a.positions[i], a.velocities[i], a.accelerations[i]
            p1, v1, a1 = b.positions[i], b.velocities[i], b.accelerations[i]
            c = [p0, v0, 0.5 * a0, 0.0, 0.0, 0.0]
            if between != 0.0:
                c[3] = (
                    -20.0 * p0 + 20.0 * p1 - 3.0 * a0 * T[2] + a1 * T[2] - 12.0 * v0 * T[1]
                    - 8.0 * v1 * T[1]
                ) / (2.0 * T[3])  # fmt: skip
                c[4] = (
                    30.0 * p0 - 30.0 * p1 + 3.0 * a0 * T[2] - 2.0 * a1 * T[2] + 16.0 * v0 * T[1]
                    + 14.0 * v1 * T[1]
                ) / (2.0 * T[4])  # fmt: skip
                c[5] = (
                    -12.0 * p0 + 12.0 * p1 - a0 * T[2] + a1 * T[2] - 6.0 * v0 * T[1]
                    - 6.0 * v1 * T[1]
                ) / (2.0 * T[5])  # fmt: skip
            pos[i] = sum(ts[k] * c[k] for k in range(6))
            vel[i] = sum(ts[k - 1] * k * c[k] for k in range(1, 6))
            acc[i] = 2.0 * c[2] + ts[1] * 6.0 * c[3] + ts[2] * 12.0 * c[4] + ts[3] * 20.0 * c[5]
    elif has_vel:
        T = [1.0, between, between * between, between * between * between]
        for i in range(dim):
            p0, v0 = a.positions[i], a.velocities[i]
            p1, v1 = b.positions[i], b.velocities[i]
            c2 = c3 = 0.0
            if between != 0.0:
                c2 = (-3.0 * p0 + 3.0 * p1 - 2.0 * v0 * T[1] - v1 * T[1]) / T[2]
                c3 = (2.0 * p0 - 2.0 * p1 + v0 * T[1] + v1 * T[1]) / T[3]
            pos[i] = p0 + ts[1] * v0 + ts[2] * c2 + ts[3] * c3
            vel[i] = v0 + ts[1] * 2.0 * c2 + ts[2] * 3.0 * c3
            acc[i] = 2.0 * c2 + ts[1] * 6.0 * c3
    else:
        for i in range(dim):
            slope = (b.positions[i] - a.positions[i]) / between if between != 0.0 else 0.0
            pos[i] = a.positions[i] + ts[1] * slope
            vel[i] = slope
    return Sample(tuple(pos), tuple(vel), tuple(acc), tuple(eff))


_VALUE = st.floats(-10.0, 10.0, allow_nan=False) | st.sampled_from([0.0, -0.0])


@st.composite
def _points(draw: st.DrawFn) -> tuple[Point, Point]:
    dim = draw(st.integers(1, 4))
    fields = [draw(st.booleans()) for _ in range(6)]  # vel, acc, eff of a, then of b

    def values(given: bool) -> tuple[float, ...]:
        return tuple(draw(st.lists(_VALUE, min_size=dim, max_size=dim))) if given else ()

    a = Point(0, values(True), values(fields[0]), values(fields[1]), values(fields[2]))
    b = Point(0, values(True), values(fields[3]), values(fields[4]), values(fields[5]))
    return a, b


@settings(max_examples=300, deadline=None)
@given(
    ends=_points(),
    t_a=st.integers(0, 3 * S),
    span=st.integers(0, 2 * S),
    at=st.integers(-S, 4 * S),
)
def test_interpolation_is_the_formula_bit_for_bit(
    ends: tuple[Point, Point], t_a: int, span: int, at: int
) -> None:
    a, b = ends
    got = interpolate(t_a, a, t_a + span, b, t_a + at)
    expected = _reference_interpolate(t_a, a, t_a + span, b, t_a + at)
    assert repr(got) == repr(expected)
