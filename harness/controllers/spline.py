"""joint_trajectory_controller's trajectory sampling and tolerances, sans-I/O.

The semantics follow ros2_controllers' ``joint_trajectory_controller`` (``trajectory.cpp``,
``tolerances.hpp``):

- A trajectory starts at its header stamp, or at its first sample when the stamp is zero. The
  segment before the first point runs from the state when it was first sampled
  (:meth:`SampledTrajectory.set_point_before`) to the first point.
- Each segment is interpolated by what both its ends give: positions only -> linear,
  positions and velocities -> cubic, positions, velocities and accelerations -> quintic.
  Outside a segment's time span the end state holds (and derivatives are dropped).
- After the last point the last point holds.
- A tolerance of 0 is not enforced; a goal's tolerance of -1 erases the default; other
  negative values are illegal (the defaults apply).

Times are integer nanoseconds of simulation time; points carry ``time_from_start`` in ns.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "Point",
    "Sample",
    "SampledTrajectory",
    "SegmentTolerances",
    "StateTolerance",
    "goal_tolerances",
    "interpolate",
    "params_tolerances",
    "within",
]

_ERASE = -1.0
_FLOAT_EPS = 1.1920929e-07  # std::numeric_limits<float>::epsilon()


@dataclass(frozen=True)
class Point:
    """A trajectory point in the controller's joint order; empty tuples are absent fields."""

    time_from_start_ns: int
    positions: tuple[float, ...]
    velocities: tuple[float, ...] = ()
    accelerations: tuple[float, ...] = ()
    effort: tuple[float, ...] = ()


@dataclass(frozen=True)
class Sample:
    """A sampled state: every field filled (one value per joint)."""

    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    accelerations: tuple[float, ...]
    effort: tuple[float, ...]


def _powers(n: int, x: float) -> list[float]:
    out = [1.0]
    for _ in range(n):
        out.append(out[-1] * x)
    return out


def interpolate(t_a: int, a: Point, t_b: int, b: Point, t: int) -> Sample:
    """The state at ``t`` on the segment from ``a`` (at ``t_a``) to ``b`` (at ``t_b``), by the
    highest spline order both ends support."""
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
    ts = _powers(5, so_far)
    pos = [0.0] * dim
    vel = [0.0] * dim
    acc = [0.0] * dim
    eff = [0.0] * dim
    # the arithmetic is written out per joint, each expression as the spline's formula
    # (same operations in the same order: the same bits), over locals for speed
    t1, t2, t3 = ts[1], ts[2], ts[3]
    if has_eff:
        ae, be = a.effort, b.effort
        for i in range(dim):
            slope = (be[i] - ae[i]) / between if between != 0.0 else 0.0
            eff[i] = ae[i] + t1 * slope
    ap, bp = a.positions, b.positions
    if has_vel and has_acc:
        T = _powers(5, between)
        T1, T2 = T[1], T[2]
        t0, t4, t5 = ts[0], ts[4], ts[5]
        av, aa, bv, ba = a.velocities, a.accelerations, b.velocities, b.accelerations
        for i in range(dim):
            p0, v0, a0 = ap[i], av[i], aa[i]
            p1, v1, a1 = bp[i], bv[i], ba[i]
            c2 = 0.5 * a0
            c3 = c4 = c5 = 0.0
            if between != 0.0:
                c3 = (
                    -20.0 * p0 + 20.0 * p1 - 3.0 * a0 * T2 + a1 * T2 - 12.0 * v0 * T1
                    - 8.0 * v1 * T1
                ) / (2.0 * T[3])  # fmt: skip
                c4 = (
                    30.0 * p0 - 30.0 * p1 + 3.0 * a0 * T2 - 2.0 * a1 * T2 + 16.0 * v0 * T1
                    + 14.0 * v1 * T1
                ) / (2.0 * T[4])  # fmt: skip
                c5 = (
                    -12.0 * p0 + 12.0 * p1 - a0 * T2 + a1 * T2 - 6.0 * v0 * T1
                    - 6.0 * v1 * T1
                ) / (2.0 * T[5])  # fmt: skip
            # sum(ts[k] * c[k]) and sum(ts[k - 1] * k * c[k]) of c = (p0, v0, c2, c3, c4, c5)
            pos[i] = sum([t0 * p0, t1 * v0, t2 * c2, t3 * c3, t4 * c4, t5 * c5])
            vel[i] = sum([t0 * 1 * v0, t1 * 2 * c2, t2 * 3 * c3, t3 * 4 * c4, t4 * 5 * c5])
            acc[i] = 2.0 * c2 + t1 * 6.0 * c3 + t2 * 12.0 * c4 + t3 * 20.0 * c5
    elif has_vel:
        T = _powers(3, between)
        T1, T2, T3 = T[1], T[2], T[3]
        av, bv = a.velocities, b.velocities
        for i in range(dim):
            p0, v0 = ap[i], av[i]
            p1, v1 = bp[i], bv[i]
            c2 = c3 = 0.0
            if between != 0.0:
                c2 = (-3.0 * p0 + 3.0 * p1 - 2.0 * v0 * T1 - v1 * T1) / T2
                c3 = (2.0 * p0 - 2.0 * p1 + v0 * T1 + v1 * T1) / T3
            pos[i] = p0 + t1 * v0 + t2 * c2 + t3 * c3
            vel[i] = v0 + t1 * 2.0 * c2 + t2 * 3.0 * c3
            acc[i] = 2.0 * c2 + t1 * 6.0 * c3
    else:
        # linear (also when accelerations come without velocities)
        for i in range(dim):
            slope = (bp[i] - ap[i]) / between if between != 0.0 else 0.0
            pos[i] = ap[i] + t1 * slope
            vel[i] = slope
    return Sample(tuple(pos), tuple(vel), tuple(acc), tuple(eff))


def _filled(point: Point) -> Sample:
    n = len(point.positions)
    zeros = (0.0,) * n
    return Sample(
        point.positions,
        point.velocities or zeros,
        point.accelerations or zeros,
        point.effort or zeros,
    )


@dataclass
class SampledTrajectory:
    """One accepted trajectory (points in the controller's joint order) and its sampling
    state. ``start_ns`` is the header stamp (0: set at the first sample)."""

    points: tuple[Point, ...]
    start_ns: int = 0
    before_ns: int = 0
    before: Point | None = None
    sampled: bool = False

    def set_point_before(self, now_ns: int, current: Point) -> None:
        """The state the trajectory starts from (velocities/accelerations zero-filled when
        the first point has them and ``current`` lacks them)."""
        first = self.points[0]
        n = len(current.positions)
        velocities = current.velocities or ((0.0,) * n if first.velocities else ())
        accelerations = current.accelerations or ((0.0,) * n if first.accelerations else ())
        self.before_ns = now_ns
        self.before = Point(0, current.positions, velocities, accelerations, current.effort)

    def sample(self, t_ns: int) -> tuple[Sample | None, int, int]:
        """``(state, start_index, end_index)`` at ``t_ns``; ``end_index == len(points)`` once
        the last point's time has passed; the state is None before the point before."""
        if not self.sampled:
            if self.start_ns == 0:
                self.start_ns = t_ns
            self.sampled = True
        if t_ns < self.before_ns:
            return None, 0, 0
        first = self.points[0]
        first_t = self.start_ns + first.time_from_start_ns
        if t_ns < first_t:
            assert self.before is not None
            return interpolate(self.before_ns, self.before, first_t, first, t_ns), 0, 0
        for i in range(len(self.points) - 1):
            a, b = self.points[i], self.points[i + 1]
            t0 = self.start_ns + a.time_from_start_ns
            t1 = self.start_ns + b.time_from_start_ns
            if t0 <= t_ns < t1:
                return interpolate(t0, a, t1, b, t_ns), i, i + 1
        last = len(self.points) - 1
        return _filled(self.points[last]), last, len(self.points)


@dataclass(frozen=True)
class StateTolerance:
    """Position, velocity and acceleration tolerances of one joint (0: not enforced)."""

    position: float = 0.0
    velocity: float = 0.0
    acceleration: float = 0.0


@dataclass(frozen=True)
class SegmentTolerances:
    """Per-joint path (``state``) and ``goal`` tolerances, and the extra ``goal_time`` (s)
    allowed after the last point to get within the goal tolerances (0: unlimited)."""

    state: tuple[StateTolerance, ...]
    goal: tuple[StateTolerance, ...]
    goal_time: float = 0.0
    notes: tuple[str, ...] = field(default=(), compare=False)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{where} must be a number, not {value!r}")
    return float(value)


def params_tolerances(joints: Sequence[str], constraints: Mapping[str, Any]) -> SegmentTolerances:
    """The default tolerances from the controller's ``constraints`` parameters
    (``goal_time``, ``stopped_velocity_tolerance`` (default 0.01), ``<joint>.trajectory``,
    ``<joint>.goal``). Raises ``ValueError`` naming a bad key."""
    goal_time = _number(constraints.get("goal_time", 0.0), "constraints.goal_time")
    stopped = _number(
        constraints.get("stopped_velocity_tolerance", 0.01),
        "constraints.stopped_velocity_tolerance",
    )
    state: list[StateTolerance] = []
    goal: list[StateTolerance] = []
    for joint in joints:
        own = constraints.get(joint, {})
        if not isinstance(own, Mapping):
            raise ValueError(f"constraints.{joint} must be a mapping, not {own!r}")
        trajectory = _number(own.get("trajectory", 0.0), f"constraints.{joint}.trajectory")
        at_goal = _number(own.get("goal", 0.0), f"constraints.{joint}.goal")
        state.append(StateTolerance(position=trajectory))
        goal.append(StateTolerance(position=at_goal, velocity=stopped))
    return SegmentTolerances(tuple(state), tuple(goal), goal_time)


def _resolve(default: float, given: float) -> float:
    if given > 0.0:
        return given
    if abs(given - _ERASE) < _FLOAT_EPS:
        return 0.0
    if given < 0.0:
        raise ValueError("illegal tolerance")
    return default


def _override(base: StateTolerance, given: Mapping[str, Any]) -> StateTolerance:
    return StateTolerance(
        _resolve(base.position, float(given.get("position", 0.0))),
        _resolve(base.velocity, float(given.get("velocity", 0.0))),
        _resolve(base.acceleration, float(given.get("acceleration", 0.0))),
    )


def goal_tolerances(
    defaults: SegmentTolerances, joints: Sequence[str], goal: Mapping[str, Any]
) -> SegmentTolerances:
    """The tolerances of a FollowJointTrajectory goal: its ``path_tolerance``,
    ``goal_tolerance`` and ``goal_time_tolerance`` over ``defaults``. An unknown joint or an
    illegal value keeps ``defaults`` (as the controller does; :attr:`SegmentTolerances.notes`
    says why)."""
    duration = goal.get("goal_time_tolerance", {"sec": 0, "nanosec": 0})
    seconds = int(duration["sec"]) + int(duration["nanosec"]) / 1e9
    try:
        goal_time = _resolve(defaults.goal_time, seconds)
    except ValueError:
        return _noted(defaults, f"illegal goal_time_tolerance {seconds:g}: default tolerances")
    index = {j: i for i, j in enumerate(joints)}
    state = list(defaults.state)
    final = list(defaults.goal)
    for key, target, base in (
        ("path_tolerance", state, defaults.state),
        ("goal_tolerance", final, defaults.goal),
    ):
        for tol in goal.get(key, ()):
            i = index.get(str(tol["name"]))
            if i is None:
                return _noted(
                    defaults, f"joint {tol['name']!r} of {key} is not a controller joint: "
                    "default tolerances",
                )  # fmt: skip
            try:
                target[i] = _override(base[i], tol)
            except ValueError:
                return _noted(
                    defaults, f"joint {tol['name']!r} has an illegal {key}: default tolerances"
                )
    return SegmentTolerances(tuple(state), tuple(final), goal_time)


def _noted(tolerances: SegmentTolerances, note: str) -> SegmentTolerances:
    return SegmentTolerances(tolerances.state, tolerances.goal, tolerances.goal_time, (note,))


def within(
    tolerance: StateTolerance, position_error: float, velocity_error: float, acc_error: float
) -> bool:
    """Whether the errors of one joint satisfy ``tolerance`` (zero tolerances are ignored)."""
    return not (
        (tolerance.position > 0.0 and abs(position_error) > tolerance.position)
        or (tolerance.velocity > 0.0 and abs(velocity_error) > tolerance.velocity)
        or (tolerance.acceleration > 0.0 and abs(acc_error) > tolerance.acceleration)
    )
