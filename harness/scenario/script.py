"""The ``script:`` key: in-process joint commands on a simulation-time timeline.

A scenario with a ``script`` needs no client program: the runner steps the world and, at the
first step boundary at or after each entry's ``at`` (simulation seconds), hands the entry's
commands to the session (:meth:`harness.session.Session.set_positions` and
:meth:`~harness.session.Session.command`). The session records them as applied inputs like any
command from a bridge client, so the recording replays bit for bit. This is what
``harness explore`` drives when examples must be cheap (no process, no socket per example).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

__all__ = ["ScriptCommand", "ScriptTarget", "run_script", "script_commands", "script_steps"]


@dataclass(frozen=True)
class ScriptCommand:
    """One ``script[]`` entry: joint -> value commands taking effect at ``at`` seconds."""

    at: float
    positions: Mapping[str, float] = field(default_factory=dict)
    velocities: Mapping[str, float] = field(default_factory=dict)
    efforts: Mapping[str, float] = field(default_factory=dict)

    def joints(self) -> list[str]:
        """Every joint this entry commands."""
        return [*self.positions, *self.velocities, *self.efforts]


class ScriptTarget(Protocol):
    """What a script drives: a :class:`harness.session.Session` (lockstep or paused)."""

    def step(self, n: int = 1) -> int: ...

    def set_positions(self, positions: Mapping[str, float]) -> Any: ...

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> Any: ...

    @property
    def step_index(self) -> int: ...


def script_commands(items: list[Mapping[str, Any]]) -> tuple[ScriptCommand, ...]:
    """The schema-valid ``script`` list as commands, in file order."""
    return tuple(
        ScriptCommand(
            at=float(item["at"]),
            positions={str(k): float(v) for k, v in item.get("positions", {}).items()},
            velocities={str(k): float(v) for k, v in item.get("velocities", {}).items()},
            efforts={str(k): float(v) for k, v in item.get("efforts", {}).items()},
        )
        for item in items
    )


def script_steps(script: tuple[ScriptCommand, ...], dt_ns: int) -> list[int]:
    """The step index at whose boundary each command is applied (it acts from the next step)."""
    return [max(0, math.ceil(round(c.at * 1e9) / dt_ns)) for c in script]


def run_script(
    target: ScriptTarget,
    script: tuple[ScriptCommand, ...],
    dt_ns: int,
    limit: int,
    chunk: int = 10,
) -> None:
    """Step ``target`` to ``limit`` steps, applying each command at its step boundary."""
    pending = sorted(zip(script_steps(script, dt_ns), script, strict=True), key=lambda p: p[0])
    k = target.step_index
    while True:
        while pending and pending[0][0] <= k:
            _apply(target, pending.pop(0)[1])
        if k >= limit:
            return
        until = min(limit, pending[0][0]) if pending else limit
        k = target.step(min(chunk, until - k))


def _apply(target: ScriptTarget, command: ScriptCommand) -> None:
    if command.positions:
        target.set_positions(dict(command.positions))
    for joint, value in command.velocities.items():
        target.command(joint, velocity=value)
    for joint, value in command.efforts.items():
        target.command(joint, effort=value)
