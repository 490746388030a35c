"""``diff``: compare two recordings on decoded records with per-quantity tolerances.

The engine of golden tests (the pytest plugin's ``golden.check(**tolerances)`` calls
:func:`diff`). Compared, at the steps both recordings hold a physics state:

- ``joint_position`` / ``joint_velocity``: every ``qpos``/``qvel`` coordinate, named after
  its joint (``box_joint[3]`` for multi-coordinate joints);
- ``link_position`` (m) / ``link_rotation`` (rad): every body's world pose, by forward
  kinematics of the recorded ``qpos`` on recording A's model;
- ``collisions``: begin/end events matched by (kind, body pair) within ``collision_time_ns``;
- ``message_count``: messages per topic (``/harness/bridge`` frames included; with
  ``ignore_after_last_step``, the ``/harness/bridge`` frames after the last step are not
  counted: see :func:`frames_after_last_step`).

- ``epochs``: the steps at which each run was reset.

Recordings from two platforms (:mod:`harness.replay.platforms`) are compared only with
tolerances: with every physics tolerance 0 the diff is refused in one line.

Bytes are never compared (headers carry library versions). A quantity differs when
``|b - a| > tolerance``; every differing quantity is one :class:`DiffEntry` naming the first
step it exceeded its tolerance, both values and their delta there, and its largest delta and
the step of it; rows are in :func:`~harness.replay.cause.divergence_order` (by step; at one
step joints first, the largest delta first), so the first row is the first divergence.
The causes are compared too (:mod:`harness.replay.cause`): the applied inputs and the
incoming bridge frames, exactly; the first one that differs at or before the first state
divergence is its cause, in one :class:`~harness.replay.cause.FirstDivergence` line.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.recording import TOPIC_BRIDGE, CollisionEvent, Recording
from harness.replay.cause import (
    FirstDivergence,
    divergence_order,
    first_cause,
    first_divergence,
)
from harness.replay.layout import StateLayout, rotation_angle
from harness.replay.platforms import check_platforms, platform_note
from harness.replay.source import open_recording, read_states, resolve_model

__all__ = [
    "DiffEntry",
    "DiffReport",
    "FirstDivergence",
    "Tolerances",
    "diff",
    "frames_after_last_step",
]

F64 = npt.NDArray[np.float64]
_KINDS = {0: "begin", 1: "end", 2: "near_miss"}


class Tolerances(NamedTuple):
    """Per-quantity tolerances (0: exact)."""

    joint_position: float = 0.0
    joint_velocity: float = 0.0
    link_position: float = 0.0
    link_rotation: float = 0.0
    collision_time_ns: int = 0
    message_count: int = 0


@dataclass(frozen=True)
class DiffEntry:
    """One quantity that differs beyond its tolerance: ``a`` and ``b`` at ``step``, the first
    step beyond it (-1: not step-based), ``delta`` between them there (NaN: not a number),
    and the largest delta, ``max_delta``, at ``max_step`` (-1: not step-based)."""

    quantity: str
    name: str
    step: int
    a: Any
    b: Any
    max_delta: float
    tolerance: float
    delta: float = math.nan
    max_step: int = -1


@dataclass(frozen=True)
class DiffReport:
    """The outcome of :func:`diff` (``same``: nothing beyond its tolerance)."""

    a: str
    b: str
    tolerances: dict[str, float]
    steps_compared: int
    entries: tuple[DiffEntry, ...]
    first_divergence: FirstDivergence | None = None
    """Where A and B first part and why (None: they never do)."""
    inputs_compared: int = 0
    frames_compared: int = 0
    notes: tuple[str, ...] = ()

    @property
    def same(self) -> bool:
        """True when every quantity is within its tolerance."""
        return not self.entries

    @property
    def first_entry(self) -> DiffEntry | None:
        """The first divergence: the row the FIRST DIVERGENCE line and the table begin with
        (:func:`~harness.replay.cause.divergence_order`); ``None`` when nothing differs."""
        return min(self.entries, key=divergence_order, default=None)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return {**asdict(self), "same": self.same}

    def format(self) -> str:
        """A readable table (the CLI's output)."""
        lines = [
            f"A: {self.a}",
            f"B: {self.b}",
            f"{self.steps_compared} common steps, {self.inputs_compared} applied inputs and "
            f"{self.frames_compared} incoming bridge frames compared",
            *[f"note: {n}" for n in self.notes],
        ]
        first = self.first_divergence
        if self.same:
            if first is not None and first.cause is not None:
                lines.append(
                    f"note: {first.cause.format()}, yet every quantity is within its tolerance"
                )
            lines.append("SAME: every quantity within its tolerance")
            return "\n".join(lines)
        if first is not None:
            lines.append(first.format())
        lines.append(
            "step: the first step beyond tolerance; A, B and delta at that step; "
            "max delta: the largest over the run, at step 'max at'"
        )
        lines.append(
            f"{'step':>7} {'quantity':<16} {'name':<28} {'A':>24} {'B':>24} {'delta':>11} "
            f"{'max delta':>11} {'max at':>7} {'tolerance':>10}"
        )
        for e in sorted(self.entries, key=divergence_order):
            step = "-" if e.step < 0 else str(e.step)
            delta = "-" if math.isnan(e.delta) else f"{e.delta:.4g}"
            max_at = "-" if e.max_step < 0 else str(e.max_step)
            lines.append(
                f"{step:>7} {e.quantity:<16} {e.name:<28} {_show(e.a):>24} {_show(e.b):>24} "
                f"{delta:>11} {e.max_delta:>11.4g} {max_at:>7} {e.tolerance:>10.3g}"
            )
        lines.append(f"DIFFERENT: {len(self.entries)} quantities beyond tolerance")
        return "\n".join(lines)


def _show(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.10g}"
    if isinstance(value, tuple):
        return ",".join(f"{v:.6g}" for v in value)
    return str(value)


def _compare_columns(
    quantity: str,
    names: list[str],
    steps: npt.NDArray[np.int64],
    a: F64,
    b: F64,
    tolerance: float,
    shown: tuple[npt.NDArray[Any], npt.NDArray[Any]] | None = None,
) -> list[DiffEntry]:
    """One entry per column of ``a``/``b`` (rows: ``steps``) beyond ``tolerance``;
    ``shown``: what to print as A and B instead of the compared values (``(rows, columns,
    ...)`` arrays, e.g. each body's position when the compared value is a distance)."""
    with np.errstate(invalid="ignore"):
        delta = np.abs(b - a)
    delta = np.where(np.isnan(a) & np.isnan(b), 0.0, delta)
    delta = np.where(np.isnan(delta), np.inf, delta)
    out: list[DiffEntry] = []
    for column in np.flatnonzero((delta > tolerance).any(axis=0)):
        rows = np.flatnonzero(delta[:, column] > tolerance)
        r = int(rows[0])
        largest = int(np.argmax(delta[:, column]))
        if shown is None:
            value_a: Any = float(a[r, column])
            value_b: Any = float(b[r, column])
        else:
            value_a = tuple(float(v) for v in np.ravel(shown[0][r, column]))
            value_b = tuple(float(v) for v in np.ravel(shown[1][r, column]))
        out.append(
            DiffEntry(
                quantity,
                names[column],
                int(steps[r]),
                value_a,
                value_b,
                float(delta[largest, column]),
                tolerance,
                float(delta[r, column]),
                int(steps[largest]),
            )
        )
    return out


def _poses(model: mujoco.MjModel, qpos: F64) -> tuple[F64, F64]:
    data = mujoco.MjData(model)
    pos = np.empty((qpos.shape[0], model.nbody, 3))
    quat = np.empty((qpos.shape[0], model.nbody, 4))
    for t in range(qpos.shape[0]):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        pos[t] = data.xpos
        quat[t] = data.xquat
    return pos, quat


def _events(rec: Recording) -> list[CollisionEvent]:
    return list(rec.collision_events())


def _match_collisions(
    a: list[CollisionEvent], b: list[CollisionEvent], tolerance_ns: int
) -> list[DiffEntry]:
    def key(e: CollisionEvent) -> tuple[str, str, str]:
        return (_KINDS.get(e.kind, str(e.kind)), e.body1, e.body2)

    unmatched_b = list(b)
    out: list[DiffEntry] = []
    for event in a:
        best = None
        for j, other in enumerate(unmatched_b):
            if (
                key(other) == key(event)
                and abs(other.sim_time_ns - event.sim_time_ns) <= tolerance_ns
            ):
                best = j
                break
        if best is None:
            kind, b1, b2 = key(event)
            where = f"at {event.sim_time_ns} ns"
            out.append(
                DiffEntry("collisions", f"{kind} {b1}|{b2}", event.step, where, "missing",
                          math.inf, tolerance_ns, math.inf, event.step)
            )  # fmt: skip
        else:
            unmatched_b.pop(best)
    for other in unmatched_b:
        kind, b1, b2 = key(other)
        out.append(DiffEntry("collisions", f"{kind} {b1}|{b2}", other.step, "missing",
                             f"at {other.sim_time_ns} ns", math.inf, tolerance_ns, math.inf,
                             other.step))  # fmt: skip
    return out


def frames_after_last_step(rec: Recording) -> int:
    """How many ``/harness/bridge`` frames of ``rec`` come after its last step: from the
    first incoming frame or marker recorded with ``step`` > :attr:`Recording.last_step`
    (applied at a boundary no step followed: sent after the last step, or the session's
    close) to the end, in recorded order, the outgoing frames they caused included. Whether
    a client's frames sent while a session closes arrive in time is wall-clock timing
    (:mod:`harness.session.live.session`, "Closing"); nothing before them is."""
    if TOPIC_BRIDGE not in rec.topics:
        return 0
    last = rec.last_step
    total = 0
    cut: int | None = None
    for i, frame in enumerate(rec.bridge_frames()):
        total = i + 1
        if cut is None and frame.direction == 0 and frame.step > last:
            cut = i
    return 0 if cut is None else total - cut


def _counts(rec: Recording, ignore_after_last_step: bool) -> dict[str, int]:
    counts = {t: i.messages for t, i in rec.topics.items()}
    if ignore_after_last_step and TOPIC_BRIDGE in counts:
        counts[TOPIC_BRIDGE] -= frames_after_last_step(rec)
    return counts


def diff(
    a: str | Path,
    b: str | Path,
    tolerances: Tolerances | None = None,
    *,
    ignore_after_last_step: bool = False,
    **overrides: float,
) -> DiffReport:
    """Compare recordings ``a`` and ``b``; ``tolerances`` (or keyword overrides of
    :class:`Tolerances` fields, e.g. ``joint_position=1e-9``) bound each quantity.
    ``ignore_after_last_step``: leave the ``/harness/bridge`` frames after each recording's
    last step out of its message count (:func:`frames_after_last_step`; golden tests)."""
    tol = (tolerances or Tolerances())._replace(**overrides)  # type: ignore[arg-type]
    entries: list[DiffEntry] = []
    with open_recording(a) as ra, open_recording(b) as rb:
        platforms = platform_note(check_platforms(ra, rb, tol._asdict()))
        model, _ = resolve_model(ra)
        sa, sb = read_states(ra), read_states(rb)
        counts_a = _counts(ra, ignore_after_last_step)
        counts_b = _counts(rb, ignore_after_last_step)
        events_a, events_b = _events(ra), _events(rb)
        epochs_a = [(e.step, e.reason) for e in ra.epochs()]
        epochs_b = [(e.step, e.reason) for e in rb.epochs()]
        cause, inputs_compared, frames_compared = first_cause(
            ra, rb, model, ignore_after_last_step=ignore_after_last_step
        )
    notes = [platforms] if platforms else []
    notes += [
        f"{label}: the state of step {int(steps[np.flatnonzero(np.diff(steps) <= 0)[0] + 1])} "
        "is recorded twice (a reset recorded before resets became epochs): the first is compared"
        for label, steps in (("A", sa.steps), ("B", sb.steps))
        if steps.size > 1 and np.any(np.diff(steps) <= 0)
    ]
    common, ia, ib = np.intersect1d(sa.steps, sb.steps, return_indices=True)
    if not np.array_equal(sa.steps, sb.steps):
        entries.append(
            DiffEntry("steps", "recorded steps", -1,
                      f"{int(sa.steps[0])}..{int(sa.steps[-1])} ({sa.steps.size})",
                      f"{int(sb.steps[0])}..{int(sb.steps[-1])} ({sb.steps.size})", math.inf, 0.0)
        )  # fmt: skip
    if sa.qpos.shape[1] != sb.qpos.shape[1] or sa.qvel.shape[1] != sb.qvel.shape[1]:
        entries.append(
            DiffEntry("model", "nq/nv", -1, f"{sa.qpos.shape[1]}/{sa.qvel.shape[1]}",
                      f"{sb.qpos.shape[1]}/{sb.qvel.shape[1]}", math.inf, 0.0)
        )  # fmt: skip
    elif common.size:
        layout = StateLayout(model, sa.state_spec)
        qa, qb = sa.qpos[ia], sb.qpos[ib]
        entries += _compare_columns("joint_position", layout.qpos_names(), common, qa, qb,
                                    tol.joint_position)  # fmt: skip
        entries += _compare_columns("joint_velocity", layout.dof_names(), common, sa.qvel[ia],
                                    sb.qvel[ib], tol.joint_velocity)  # fmt: skip
        if qa.shape[1] == model.nq:
            pa, oa = _poses(model, qa)
            pb, ob = _poses(model, qb)
            bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or f"body{i}"
                      for i in range(model.nbody)]  # fmt: skip
            dist = np.linalg.norm(pb - pa, axis=2)
            angle = rotation_angle(oa, ob)
            entries += _compare_columns("link_position", bodies, common, np.zeros_like(dist),
                                        dist, tol.link_position, (pa, pb))  # fmt: skip
            entries += _compare_columns("link_rotation", bodies, common, np.zeros_like(angle),
                                        angle, tol.link_rotation, (oa, ob))  # fmt: skip
    entries += _match_collisions(events_a, events_b, int(tol.collision_time_ns))
    for topic in sorted(set(counts_a) | set(counts_b)):
        na, nb = counts_a.get(topic, 0), counts_b.get(topic, 0)
        if abs(na - nb) > tol.message_count:
            entries.append(
                DiffEntry("message_count", topic, -1, na, nb, float(abs(na - nb)),
                          float(tol.message_count), float(abs(na - nb)))
            )  # fmt: skip
    if epochs_a != epochs_b:
        pairs = zip(epochs_a, epochs_b, strict=False)
        i = next((i for i, (x, y) in enumerate(pairs) if x != y), None)
        if i is None:  # one is a prefix of the other
            i = min(len(epochs_a), len(epochs_b))
        steps = [e[i][0] for e in (epochs_a, epochs_b) if i < len(e)]
        entries.append(
            DiffEntry("epochs", "resets after step", min(steps),
                      ",".join(str(s) for s, _ in epochs_a) or "none",
                      ",".join(str(s) for s, _ in epochs_b) or "none", math.inf, 0.0)
        )  # fmt: skip
    entries.sort(key=divergence_order)
    return DiffReport(
        str(a), str(b), dict(tol._asdict()), int(common.size), tuple(entries),
        first_divergence(entries, cause, ra.timestep_ns), inputs_compared, frames_compared,
        tuple(notes),
    )  # fmt: skip
