"""What one iteration is asked to do and what it hands back, and how it is judged.

:class:`IterationRunner` is the narrow interface between the runner machinery (iterations,
workers, reports) and whatever runs one iteration: the session-backed runner, or the stand-ins
in :mod:`tests.scenario.standins`. Everything here is a frozen dataclass of plain values so
it pickles to worker processes and Dask workers and serialises to ``results.json``.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Protocol

from harness.scenario.scenario import ClientSpec, Criteria, Scenario

__all__ = [
    "ClientOutcome",
    "ClientStatus",
    "CollisionSummary",
    "IterationResult",
    "IterationRunner",
    "IterationSpec",
    "JointLimitSummary",
    "JointTrace",
    "Traces",
    "Verdict",
    "criteria_settings",
    "judge",
]


@dataclass(frozen=True)
class IterationSpec:
    """One iteration to run.

    ``port`` 0 means a free port chosen when the bridge binds; ``out_dir`` is this iteration's
    own folder (client log, extra artifacts); ``recording_path`` is where its MCAP goes.
    ``sim_time_limit`` (seconds of simulation time) ends the run if the client has not exited.
    """

    simulation: str
    iteration: int
    scenario: Scenario
    client: ClientSpec | None
    sim_time_limit: float
    seed: int
    host: str
    port: int
    out_dir: Path
    recording_path: Path


@dataclass(frozen=True)
class Verdict:
    """One judged criterion: ``name`` ("client", "collisions", "joint_limits", "determinism",
    ...), whether it passed, and a one-line ``detail``."""

    name: str
    passed: bool
    detail: str


@dataclass(frozen=True)
class CollisionSummary:
    """One contact episode between two bodies, in simulation seconds (``end`` None: still in
    contact when the run ended). ``body1`` is a robot's body when either is. ``world``: neither
    body is a robot's (a box on a table); ``initial``: the pair was in contact at the start
    (the first step's contacts are those of the initial state); ``support``: every contact
    was one of the robot with what supports it (:mod:`harness.events.support`)."""

    body1: str
    body2: str
    begin: float
    end: float | None
    peak_depth: float
    peak_force: float
    world: bool = False
    initial: bool = False
    support: bool = False


@dataclass(frozen=True)
class JointLimitSummary:
    """Range a joint reached against its limits; ``max_excess`` is the largest distance beyond
    a limit (0 when respected), ``violation_steps`` how many steps were beyond."""

    joint: str
    lower: float | None
    upper: float | None
    min_position: float
    max_position: float
    max_excess: float
    violation_steps: int
    tolerance: float = 0.0
    """The excess the solver allows this joint (:func:`harness.events.solver_limit_tolerance`);
    ``violation_steps`` counts the steps beyond it."""


@dataclass(frozen=True)
class JointTrace:
    """Sampled position and velocity of one joint (aligned with :attr:`Traces.time`), the
    commanded position where there was one (NaN where none), and its limits."""

    joint: str
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    command: tuple[float, ...] | None = None
    lower: float | None = None
    upper: float | None = None
    velocity_limit: float | None = None


@dataclass(frozen=True)
class Traces:
    """Time series for the report: ``time`` in simulation seconds."""

    time: tuple[float, ...]
    joints: tuple[JointTrace, ...]


ClientStatus = Literal["exited", "sim_limit", "not_ready", "wall_timeout", "no_client"]


@dataclass(frozen=True)
class ClientOutcome:
    """How the client under test ended.

    ``status``: ``exited`` (on its own, ``exit_code`` tells how), ``sim_limit`` (stopped when
    the sim-time limit was reached), ``not_ready`` (never connected: within the readiness
    timeout, or before exiting), ``wall_timeout`` (stopped after the wall-time limit),
    ``no_client``.
    """

    status: ClientStatus
    exit_code: int | None
    reason: str
    log_path: Path | None = None
    wall_seconds: float = 0.0

    @property
    def passed(self) -> bool:
        """A client passes when it exited with 0 or was still running at the sim-time limit."""
        if self.status == "exited":
            return self.exit_code == 0
        return self.status in ("sim_limit", "no_client")


@dataclass(frozen=True)
class IterationResult:
    """Everything one iteration produced. ``error`` is set when the iteration could not run
    to an end (runner exception, worker died); ``verdicts`` hold what was judged; ``notes``
    are things worth knowing that do not fail it (a log sink that dropped events, ...)."""

    simulation: str
    iteration: int
    verdicts: tuple[Verdict, ...]
    sim_time: float
    steps: int
    recording: Path | None = None
    collisions: tuple[CollisionSummary, ...] = ()
    joint_limits: tuple[JointLimitSummary, ...] = ()
    traces: Traces | None = None
    state_digest: str | None = None
    client: ClientOutcome | None = None
    port: int | None = None
    wall_seconds: float = 0.0
    error: str | None = None
    notes: tuple[str, ...] = ()
    settings: tuple[str, ...] = ()
    """The verdict settings in force, each with how to change it (:func:`criteria_settings`)."""

    @property
    def passed(self) -> bool:
        """No error and every verdict passed."""
        return self.error is None and all(v.passed for v in self.verdicts)

    @property
    def reason(self) -> str | None:
        """Why it failed, one line (None when it passed)."""
        if self.error is not None:
            return self.error
        failed = [f"{v.name}: {v.detail}" for v in self.verdicts if not v.passed]
        return "; ".join(failed) if failed else None

    @property
    def replay_command(self) -> str | None:
        """The command that replays this iteration's recording."""
        return None if self.recording is None else f"harness replay {self.recording}"


class IterationRunner(Protocol):
    """Runs one iteration. Implementations must be picklable (they travel to worker processes)
    and must leave no process behind, whatever happens."""

    def __call__(self, spec: IterationSpec) -> IterationResult:
        """Run ``spec`` and return its result (failures are results, not exceptions)."""
        ...


def _pair_allowed(a: str, b: str, allowed: Sequence[tuple[str, str]]) -> bool:
    for pa, pb in allowed:
        if (fnmatch.fnmatchcase(a, pa) and fnmatch.fnmatchcase(b, pb)) or (
            fnmatch.fnmatchcase(a, pb) and fnmatch.fnmatchcase(b, pa)
        ):
            return True
    return False


def judged_collisions(
    criteria: Criteria, collisions: Sequence[CollisionSummary]
) -> list[CollisionSummary]:
    """The episodes the collision verdict concerns: a robot's contacts that began after the
    start and are not support contacts, unless the criteria also judge world-only, initial or
    support contacts."""
    return [
        c
        for c in collisions
        if (criteria.world_collisions or not c.world)
        and (criteria.initial_contacts or not c.initial)
        and (criteria.support_contacts or not c.support)
    ]


def criteria_settings(criteria: Criteria) -> tuple[str, ...]:
    """Every verdict setting in force, one line each, with the scenario key that changes it."""
    lines: list[str] = []
    if not criteria.no_collisions:
        lines.append("collisions: not judged (criteria.no_collisions: true judges them)")
    else:
        allowed = ", ".join(f"{a} - {b}" for a, b in criteria.allowed_collisions) or "none"
        lines += [
            "collisions: a robot's contacts fail the run (criteria.no_collisions: false "
            "turns the verdict off)",
            f"collisions: allowed pairs: {allowed} (criteria.allowed_collisions: [[a, b]], "
            "shell-style patterns)",
            (
                "collisions: contacts between world objects only are recorded, not judged "
                "(criteria.world_collisions: true judges them)"
                if not criteria.world_collisions
                else "collisions: contacts between world objects are judged too "
                "(criteria.world_collisions: false records them only)"
            ),
            (
                "collisions: contacts present at the start are not violations "
                "(criteria.initial_contacts: true judges them)"
                if not criteria.initial_contacts
                else "collisions: contacts present at the start are judged too "
                "(criteria.initial_contacts: false exempts them)"
            ),
            (
                "collisions: a robot's support contacts (wheels and casters on any surface, "
                "its floor; normal within 30 deg of vertical) are not violations "
                "(criteria.support_contacts: true judges them)"
                if not criteria.support_contacts
                else "collisions: a robot's support contacts are judged too "
                "(criteria.support_contacts: false exempts them)"
            ),
        ]
    if not criteria.joint_limits:
        lines.append("joint limits: not judged (criteria.joint_limits: true judges them)")
    elif criteria.joint_limit_tolerance is None:
        lines.append(
            "joint limits: tolerance per joint = the solver's soft-limit zone (limit margin + "
            "solimp width; 0.001 by MuJoCo's default) (criteria.joint_limit_tolerance: X sets one)"
        )
    else:
        lines.append(
            f"joint limits: tolerance {criteria.joint_limit_tolerance:g} for every joint "
            "(criteria.joint_limit_tolerance; remove it for the solver's own per joint)"
        )
    lines.append(
        "determinism: "
        + ("judged across iterations" if criteria.deterministic else "not judged")
        + " (criteria.deterministic, or harness run --check-determinism)"
    )
    return tuple(lines)


def judge(
    criteria: Criteria,
    client: ClientOutcome | None,
    collisions: Sequence[CollisionSummary],
    joint_limits: Sequence[JointLimitSummary],
) -> tuple[Verdict, ...]:
    """The verdicts of one iteration from the scenario's criteria (determinism is judged
    across iterations by the runner)."""
    verdicts: list[Verdict] = []
    if client is not None:
        verdicts.append(Verdict("client", client.passed, client.reason))
    if criteria.no_collisions:
        judged = judged_collisions(criteria, collisions)
        bad = [
            c for c in judged if not _pair_allowed(c.body1, c.body2, criteria.allowed_collisions)
        ]
        if bad:
            first = bad[0]
            detail = (
                f"{len(bad)} disallowed collision(s); first {first.body1} - {first.body2} "
                f"at t={first.begin:.3f} s (depth {first.peak_depth:.4g} m, "
                f"force {first.peak_force:.4g} N)"
            )
        else:
            allowed = len(judged)
            detail = "no collisions" if not allowed else f"only allowed collisions ({allowed})"
            support = [c for c in collisions if c.support and c not in judged]
            unjudged = len(collisions) - len(judged) - len(support)
            if unjudged:
                detail += f"; {unjudged} world or initial contact(s) recorded, not judged"
        if not criteria.support_contacts:
            pairs = sorted({f"{c.body1} - {c.body2}" for c in collisions if c.support})
            if pairs:
                detail += f"; support contacts, not judged: {', '.join(pairs)}"
        verdicts.append(Verdict("collisions", not bad, detail))
    if criteria.joint_limits:
        fixed = criteria.joint_limit_tolerance

        def tolerance(j: JointLimitSummary) -> float:
            return j.tolerance if fixed is None else fixed

        bad_j = [j for j in joint_limits if j.max_excess > tolerance(j)]
        if bad_j:
            worst = max(bad_j, key=lambda j: j.max_excess - tolerance(j))
            detail = (
                f"{len(bad_j)} joint(s) beyond limits; worst {worst.joint} by "
                f"{worst.max_excess:.4g} (tolerance {tolerance(worst):.4g}) "
                f"for {worst.violation_steps} step(s)"
            )
        else:
            detail = f"{len(joint_limits)} joint(s) within limits"
        verdicts.append(Verdict("joint_limits", not bad_j, detail))
    return tuple(verdicts)
