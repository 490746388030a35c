"""Why two recordings part: their causes compared, exactly.

What changes a run is what went into it: the applied inputs (``/harness/inputs``) and the
incoming bridge frames and markers (``/harness/bridge``, direction in). :func:`first_cause`
walks both in order and names the first that differs; :func:`first_divergence` puts it
together with the first state quantity beyond its tolerance into one line: where A and B
first part, and why. A difference after the first state divergence is a consequence (a
client reacting to a different state), not a cause.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import mujoco
import numpy as np

from harness.recording import AppliedInput, BridgeFrame, Recording
from harness.sim.bits import differing, same_bits
from harness.sim.inputs import ARRAY_FIELDS

__all__ = [
    "Cause",
    "DivergenceRow",
    "FirstDivergence",
    "divergence_order",
    "first_cause",
    "first_divergence",
]

_EXCERPT = 48


class DivergenceRow(Protocol):
    """What the first divergence reads of a diff's row (a :class:`~harness.replay.diff.DiffEntry`,
    whose module imports this one)."""

    @property
    def quantity(self) -> str: ...

    @property
    def name(self) -> str: ...

    @property
    def step(self) -> int: ...

    @property
    def a(self) -> Any: ...

    @property
    def b(self) -> Any: ...

    @property
    def delta(self) -> float: ...


@dataclass(frozen=True)
class Cause:
    """The first input that differs: an applied ``input`` field or an incoming ``frame``."""

    kind: Literal["input", "frame"]
    step: int
    what: str
    a: str
    b: str

    def format(self) -> str:
        """``applied input ctrl[1] (joint2) differs at step 506: A 0.1, B 0.12``."""
        name = "applied input" if self.kind == "input" else "incoming frame"
        return f"{name} {self.what} differs at step {self.step}: A {self.a}, B {self.b}"


@dataclass(frozen=True)
class FirstDivergence:
    """Where A and B first part (``step``) and why (``cause``; ``None``: no input differs
    up to there, so the physics itself does: model, MuJoCo version, platform), with the
    first state quantity beyond its tolerance (``quantity``; "" when none is)."""

    step: int
    sim_time_ns: int
    cause: Cause | None
    quantity: str

    def format(self) -> str:
        """One line."""
        head = f"FIRST DIVERGENCE at step {self.step} (sim time {self.sim_time_ns / 1e9:.6f} s)"
        cause = (
            self.cause.format()
            if self.cause is not None
            else "no applied input or incoming frame differs up to here (the physics itself "
            "differs: model, MuJoCo version or platform)"
        )
        state = f"; first state difference: {self.quantity}" if self.quantity else ""
        return f"{head}: cause: {cause}{state}"


def _excerpt(a: str, b: str) -> tuple[str, str]:
    """The two texts around their first difference."""
    at = next(
        (i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), min(len(a), len(b))
    )
    start = max(at - _EXCERPT // 2, 0)

    def cut(text: str) -> str:
        piece = text[start : start + _EXCERPT]
        return ("..." if start else "") + piece + ("..." if start + _EXCERPT < len(text) else "")

    return repr(cut(a)), repr(cut(b))


def _input_label(model: mujoco.MjModel, inp: AppliedInput, name: str, j: int) -> str:
    label = f"{name}[{j}]"
    if name == "ctrl":
        actuator = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, j)
        return f"{label} ({actuator})" if actuator else label
    if name == "qpos_value" and j < inp.qpos_index.size:
        adr = int(inp.qpos_index[j])
        joint = int(np.searchsorted(model.jnt_qposadr, adr, side="right")) - 1
        jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) if joint >= 0 else ""
        return f"{label} ({jname})" if jname else label
    return label


def _input_cause(
    model: mujoco.MjModel, a: list[AppliedInput], b: list[AppliedInput]
) -> Cause | None:
    for x, y in zip(a, b, strict=False):
        if x.step != y.step:
            step = min(x.step, y.step)
            return Cause(
                "input", step, "(a new input)",
                "one" if x.step == step else "none", "one" if y.step == step else "none",
            )  # fmt: skip
        if tuple(x.kinematic_joints) != tuple(y.kinematic_joints):
            return Cause(
                "input", x.step, "kinematic_joints", repr(x.kinematic_joints),
                repr(y.kinematic_joints),
            )  # fmt: skip
        for name in ARRAY_FIELDS:
            dtype = np.uint32 if name.endswith("_index") else np.float64
            va = np.asarray(getattr(x, name), dtype=dtype).reshape(-1)
            vb = np.asarray(getattr(y, name), dtype=dtype).reshape(-1)
            if va.shape != vb.shape:
                return Cause("input", x.step, f"{name} size", str(va.size), str(vb.size))
            if same_bits(va, vb):
                continue
            differ = np.flatnonzero(differing(va, vb))
            if differ.size:
                j = int(differ[0])
                return Cause(
                    "input", x.step, _input_label(model, x, name, j),
                    repr(va[j].item()), repr(vb[j].item()),
                )  # fmt: skip
    if len(a) != len(b):
        extra = a[len(b)] if len(a) > len(b) else b[len(a)]
        return Cause(
            "input", extra.step, "(a new input)",
            "one" if len(a) > len(b) else "none", "one" if len(b) > len(a) else "none",
        )  # fmt: skip
    return None


def _frame_key(f: BridgeFrame) -> tuple[int, int, str, str, str | bytes]:
    return (f.step, f.connection, f.op, f.topic, f.payload)


def _frame_cause(a: list[BridgeFrame], b: list[BridgeFrame]) -> Cause | None:
    for i, (x, y) in enumerate(zip(a, b, strict=False)):
        if _frame_key(x) == _frame_key(y):
            continue
        what = f"#{i} ({x.op or 'marker'} {x.topic or '-'}, connection {x.connection})"
        if x.step != y.step:
            return Cause(
                "frame", min(x.step, y.step), what, f"at step {x.step}", f"at step {y.step}"
            )
        ta = x.data.hex() if x.binary else x.text
        tb = y.data.hex() if y.binary else y.text
        ea, eb = _excerpt(ta, tb)
        return Cause("frame", x.step, what, ea, eb)
    if len(a) != len(b):
        extra = a[len(b)] if len(a) > len(b) else b[len(a)]
        what = f"#{min(len(a), len(b))} ({extra.op or 'marker'} {extra.topic or '-'})"
        return Cause(
            "frame", extra.step, what, "sent" if len(a) > len(b) else "none",
            "sent" if len(b) > len(a) else "none",
        )  # fmt: skip
    return None


def _incoming(rec: Recording, ignore_after_last_step: bool) -> list[BridgeFrame]:
    last = rec.last_step
    return [
        f
        for f in rec.bridge_frames()
        if f.direction == 0 and not (ignore_after_last_step and f.step > last)
    ]


def first_cause(
    a: Recording, b: Recording, model: mujoco.MjModel, *, ignore_after_last_step: bool = False
) -> tuple[Cause | None, int, int]:
    """The earliest applied input or incoming frame (markers included) that differs between
    ``a`` and ``b`` (a frame first on the same step: frames cause inputs), and how many
    inputs and frames were compared. ``ignore_after_last_step``: frames applied after each
    recording's last step are left out."""
    inputs_a, inputs_b = list(a.applied_inputs()), list(b.applied_inputs())
    frames_a = _incoming(a, ignore_after_last_step)
    frames_b = _incoming(b, ignore_after_last_step)
    causes = [
        c
        for c in (_frame_cause(frames_a, frames_b), _input_cause(model, inputs_a, inputs_b))
        if c is not None
    ]
    cause = min(causes, key=lambda c: (c.step, c.kind != "frame")) if causes else None
    return cause, min(len(inputs_a), len(inputs_b)), min(len(frames_a), len(frames_b))


def first_divergence(
    entries: Sequence[DivergenceRow], cause: Cause | None, dt_ns: int
) -> FirstDivergence | None:
    """The first-divergence line of a diff: the first state row (:func:`divergence_order`)
    and the cause, when it comes no later than that row."""
    rows = [e for e in entries if e.step >= 0]
    if not rows and cause is None:
        return None
    first = min(rows, key=divergence_order) if rows else None
    if first is not None and cause is not None and cause.step > first.step:
        cause = None  # a consequence of the divergence, not its cause
    step = first.step if first is not None else cause.step if cause is not None else 0
    quantity = ""
    if first is not None:
        quantity = (
            f"{first.quantity} {first.name} at step {first.step} "
            f"(A {_plain(first.a)}, B {_plain(first.b)})"
        )
    return FirstDivergence(step, step * dt_ns, cause, quantity)


_RANK = {"joint_position": 0, "joint_velocity": 1, "link_position": 2, "link_rotation": 3}


def divergence_order(entry: DivergenceRow) -> tuple[bool, int, int, float, str, str]:
    """The order of a diff's rows; the first is *the* first divergence (the golden failure's
    headline, the FIRST DIVERGENCE line, the table's first row): by the step it is first
    beyond its tolerance (rows without a step last), joints before links, then the largest
    difference at that step first."""
    delta = _delta(entry.a, entry.b) if math.isnan(entry.delta) else entry.delta
    return (entry.step < 0, entry.step, _RANK.get(entry.quantity, 9), -delta, entry.quantity,
            entry.name)  # fmt: skip


def _delta(a: object, b: object) -> float:
    """How far apart two shown values are (0 when not numbers): for rows without a delta."""
    if isinstance(a, float) and isinstance(b, float):
        return abs(b - a)
    if isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b):
        return float(np.linalg.norm(np.subtract(b, a)))
    return 0.0


def _plain(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.10g}"
    if isinstance(value, tuple):
        return "(" + ", ".join(f"{v:.6g}" for v in value) + ")"
    return str(value)
