"""Joint commands of a :class:`~harness.sim.Simulation`: checked, clamped to each joint's
command range and written into the per-joint command array, with a :class:`Notice` for what a
command did not do as asked.

A :class:`CommandTable` holds the commands (one value per controllable joint, in the unit of its
mode's field) and the per-row facts a command reads; the simulation decides when the commands
take effect (at the next step boundary). Bad input (unknown joint, not a finite number) raises
:class:`~harness.sim.errors.CommandError` before any value applies.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Literal, NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.errors import CommandError
from harness.sim.layout import JointLayout

__all__ = [
    "CommandField",
    "CommandTable",
    "Entry",
    "Notice",
    "body_wrench",
    "joint_state_entries",
]

CommandField = Literal["position", "velocity", "effort"]
Entry = tuple[str, str, object]
"""One requested command: ``(joint, field, value)``, not yet checked."""

_FIELD_OF_MODE: dict[str, CommandField] = {
    "kinematic": "position",
    "position": "position",
    "velocity": "velocity",
    "effort": "effort",
}


class Notice(NamedTuple):
    """Something a command did not do as asked: ``kind`` is ``"clamped"`` (``applied`` is the
    value used) or ``"ignored"`` (the field does not apply to the joint's mode; ``applied`` is
    NaN). The session turns notices into warning events."""

    joint: str
    kind: Literal["clamped", "ignored"]
    field: CommandField
    requested: float
    applied: float
    message: str


def joint_state_entries(
    name: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float],
    effort: Sequence[float],
) -> list[Entry]:
    """The entries of a ``sensor_msgs/JointState``-style command: ``effort[i]``,
    ``velocity[i]`` and ``position[i]`` for ``name[i]`` where that index exists."""
    entries: list[Entry] = []
    for field, values in (("effort", effort), ("velocity", velocity), ("position", position)):
        if len(values) > len(name):
            raise CommandError(
                f"joint state command has {len(values)} {field} values for {len(name)} names"
            )
        entries.extend((name[i], field, values[i]) for i in range(len(values)))
    return entries


def body_wrench(
    model: mujoco.MjModel, body: str, force: Sequence[float], torque: Sequence[float]
) -> tuple[int, npt.NDArray[np.float64]]:
    """``(body id, [force, torque])`` of a wrench to apply at ``body``, checked."""
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
    if bid <= 0:
        raise CommandError(f"unknown body {body!r} for apply_wrench")
    wrench = np.array([*force, *torque], dtype=np.float64)
    if wrench.shape != (6,) or not np.all(np.isfinite(wrench)):
        raise CommandError(f"body {body!r}: force and torque must be 3 finite values each")
    return bid, wrench


class CommandTable:
    """The command per controllable joint (``cmd``, updated in place) and how commands apply.

    :meth:`apply` and :meth:`apply_field` return the notices and which kinds of joints got a
    new command: ``(notices, kinematic, dynamic)``."""

    def __init__(self, layout: JointLayout) -> None:
        self.names = layout.names
        self.modes = layout.modes
        self.index = {n: i for i, n in enumerate(layout.names)}
        self.cmd: npt.NDArray[np.float64] = np.zeros(len(layout.names), dtype=np.float64)
        # Per-row facts as plain Python values: commands read them for every joint they name.
        self.wanted = tuple(_FIELD_OF_MODE[m] for m in layout.modes)
        self.row_is_kin = tuple(m == "kinematic" for m in layout.modes)
        self.lows = layout.lows
        self.highs = layout.highs
        self.qadr = layout.qadr

    def hold(self, qpos: npt.NDArray[np.float64]) -> None:
        """Commands that hold every joint where ``qpos`` has it: kinematic joints at that
        position, position servos there (clamped to their range), velocity and effort 0."""
        cmd, lows, highs = self.cmd, self.lows, self.highs
        for r, mode in enumerate(self.modes):
            q = float(qpos[self.qadr[r]])
            if mode == "kinematic":
                cmd[r] = q
            elif mode == "position":
                cmd[r] = min(max(q, lows[r]), highs[r])
            else:
                cmd[r] = 0.0

    def validate(self, entries: Iterable[Entry]) -> list[tuple[int, str, float]]:
        """``(row, field, value)`` per entry; raises on an unknown joint or a bad value."""
        out: list[tuple[int, str, float]] = []
        for joint, field, raw in entries:
            row = self.index.get(joint)
            if row is None:
                known = ", ".join(self.names) or "none"
                raise CommandError(f"unknown joint {joint!r} (controllable joints: {known})")
            try:
                value = float(raw)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise CommandError(f"joint {joint!r}: {field} {raw!r} is not a number") from None
            if not math.isfinite(value):
                raise CommandError(f"joint {joint!r}: {field} {value!r} is not finite")
            out.append((row, field, value))
        return out

    def apply(self, entries: list[tuple[int, str, float]]) -> tuple[list[Notice], bool, bool]:
        """Apply validated entries: per joint the field of its mode, clamped; the others are
        reported as ignored when nothing applies to the joint."""
        notices: list[Notice] = []
        by_row: dict[int, dict[str, float]] = {}
        for row, field, value in entries:
            by_row.setdefault(row, {})[field] = value
        kin = dyn = False
        for row, fields in by_row.items():
            wanted = self.wanted[row]
            if wanted not in fields:
                for field, value in fields.items():
                    notices.append(self.ignored(row, field, value))
                continue
            value = fields[wanted]
            applied = min(max(value, self.lows[row]), self.highs[row])
            if applied != value:
                notices.append(self.clamped(row, value, applied))
            self.cmd[row] = applied
            if self.row_is_kin[row]:
                kin = True
            else:
                dyn = True
        return notices, kin, dyn

    def apply_field(
        self, field: CommandField, values: Mapping[str, float]
    ) -> tuple[list[Notice], bool, bool]:
        """Commands of one field, one per joint (a mapping names each joint once): what
        ``apply(validate(...))`` does for them, in one pass (a client may send these every
        step). Every value is checked before any applies."""
        index, wanted, lows, highs = self.index, self.wanted, self.lows, self.highs
        notices: list[Notice] = []
        writes: list[tuple[int, float]] = []
        for joint, raw in values.items():
            row = index.get(joint)
            if row is None:
                known = ", ".join(self.names) or "none"
                raise CommandError(f"unknown joint {joint!r} (controllable joints: {known})")
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise CommandError(f"joint {joint!r}: {field} {raw!r} is not a number") from None
            if not math.isfinite(value):
                raise CommandError(f"joint {joint!r}: {field} {value!r} is not finite")
            if wanted[row] != field:
                notices.append(self.ignored(row, field, value))
                continue
            # min(max(value, low), high), for less
            applied = value
            if applied < lows[row]:
                applied = lows[row]
            if applied > highs[row]:
                applied = highs[row]
            if applied != value:
                notices.append(self.clamped(row, value, applied))
            writes.append((row, applied))
        cmd, row_is_kin = self.cmd, self.row_is_kin
        kin = dyn = False
        for row, applied in writes:
            cmd[row] = applied
            if row_is_kin[row]:
                kin = True
            else:
                dyn = True
        return notices, kin, dyn

    def ignored(self, row: int, field: str, value: float) -> Notice:
        """The notice of a ``field`` command that does not apply to ``row``'s mode."""
        name, mode = self.names[row], self.modes[row]
        return Notice(
            name,
            "ignored",
            field,  # type: ignore[arg-type]
            value,
            math.nan,
            f"joint {name!r} is {mode}-controlled: {field} command ignored",
        )

    def clamped(self, row: int, value: float, applied: float) -> Notice:
        """The notice of a command ``value`` clamped to ``applied`` (the row's range)."""
        name, wanted = self.names[row], self.wanted[row]
        lo, hi = self.lows[row], self.highs[row]
        return Notice(
            name,
            "clamped",
            wanted,
            value,
            applied,
            f"joint {name!r}: {wanted} {value:g} is beyond its limits "
            f"[{lo:g}, {hi:g}]: clamped to {applied:g}",
        )
