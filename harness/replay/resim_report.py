"""The report of a kinematic <-> dynamic re-simulation (:func:`~harness.replay.resimulate`):
the :class:`Thresholds` a difference must pass to count, the :class:`Finding` of each, one
:class:`RunSummary` per run (a :class:`JointSummary` per joint) and the :class:`ResimReport`
that puts the recorded run and the re-simulation side by side (a table, JSON)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

from harness.vocabulary import Actuation

__all__ = ["Finding", "JointSummary", "ResimReport", "RunSummary", "Thresholds"]


class Thresholds(NamedTuple):
    """Limits above which a quantity is a :class:`Finding` (and the exit code non-zero)."""

    max_tracking_error: float = 0.05
    """rad (or m): |q - q_target| of a joint."""
    max_limit_violation: float = 1e-3
    """rad (or m) beyond a joint's position limit."""
    max_velocity_ratio: float = 1.0
    """|qvel| / the description's velocity limit."""
    max_penetration: float = 0.005
    """m: the deepest contact penetration."""
    max_energy_jump: float = 0.5
    """J: total (kinetic + potential) energy rise from one step to the next."""


@dataclass(frozen=True)
class Finding:
    """The first step at which the two runs differ in ``quantity`` of ``name``: ``run`` is
    the run that exceeded the threshold there (``"recorded"`` or ``"resimulated"``; for a
    ``deviation``, always ``"resimulated"``), ``value`` its value; ``recorded_value`` and
    ``resimulated_value`` both runs' values at that step, in ``unit``."""

    run: str  # "recorded" or "resimulated"
    quantity: str  # deviation, tracking_error, limit_violation, velocity_ratio, penetration,
    # energy_jump, unstable
    name: str  # joint name ("" for whole-run quantities)
    step: int
    value: float
    threshold: float
    recorded_value: float = math.nan
    resimulated_value: float = math.nan
    unit: str = ""

    def format(self) -> str:
        """One line."""
        what = f"{self.name} {self.quantity}".strip()
        unit = f" {self.unit}" if self.unit else ""
        if self.quantity == "unstable":
            return f"step {self.step:>6}  the re-simulation became unstable (MuJoCo warning)"
        if self.quantity == "deviation":
            return (
                f"step {self.step:>6}  {what}: re-simulated {self.resimulated_value:.4g}{unit}, "
                f"recorded {self.recorded_value:.4g}{unit}: {self.value:.4g}{unit} apart "
                f"(threshold {self.threshold:g}{unit})"
            )
        only = "recording" if self.run == "recorded" else "re-simulation"
        return (
            f"step {self.step:>6}  {what}: recorded {self.recorded_value:.4g}{unit}, "
            f"re-simulated {self.resimulated_value:.4g}{unit}: only the {only} exceeds "
            f"{self.threshold:g}{unit}"
        )


@dataclass(frozen=True)
class JointSummary:
    """One joint's worst values in one run, with the step of each (-1: never above 0);
    ``unit``: of its positions (``rad`` for hinges, ``m`` for slides)."""

    joint: str
    max_tracking_error: float
    tracking_step: int
    max_limit_violation: float
    violation_step: int
    max_velocity_ratio: float
    velocity_step: int
    unit: str = "rad"


@dataclass(frozen=True)
class RunSummary:
    """One run's metrics."""

    label: str
    control: str
    joints: tuple[JointSummary, ...]
    peak_penetration: float
    penetration_step: int
    max_energy_jump: float
    energy_step: int
    contact_pairs: dict[str, int]  # "body1|body2" -> first step in contact
    unstable_at: int | None


@dataclass(frozen=True)
class ResimReport:
    """Recorded run and re-simulation side by side (``passed``: no finding, i.e. the
    re-simulation behaves as the recording did within the thresholds)."""

    path: str
    actuation: Actuation
    steps: int
    thresholds: dict[str, float]
    recorded: RunSummary
    resimulated: RunSummary
    findings: tuple[Finding, ...]
    contacts_appearing: tuple[str, ...]
    contacts_disappearing: tuple[str, ...]
    wall_seconds: float
    notes: tuple[str, ...] = ()
    recorded_reproduced: bool = True
    """Whether replaying the recorded run from its inputs gave the recorded states."""

    @property
    def passed(self) -> bool:
        """True when the re-simulation differs from the recording in nothing measured."""
        return not self.findings

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return {**asdict(self), "passed": self.passed}

    def format(self) -> str:
        """A legend, the side-by-side table, one line per finding and a verdict."""
        a, b = self.recorded, self.resimulated
        lines = [
            f"{self.path}: {self.steps} steps, recorded ({a.control}) vs re-simulated "
            f"({b.control})",
            *[f"note: {n}" for n in self.notes],
            "legend: each cell is recorded | re-simulated: the worst value of the run and, "
            "after @, the step it was reached at; '-': no limit in the description",
        ]

        def cell(value: float, step: int) -> str:
            text = "-" if math.isnan(value) else f"{value:.4g}"
            if step >= 0 and not math.isnan(value) and value > 0:
                text += f" @{step}"
            return text

        def pair(x: float, xs: int, y: float, ys: int) -> tuple[str, str]:
            return cell(x, xs), cell(y, ys)

        header = ("joint", "unit", "tracking error", "limit violation", "speed / limit")
        rows: list[tuple[str, str, tuple[str, str], tuple[str, str], tuple[str, str]]] = []
        for ja, jb in zip(a.joints, b.joints, strict=True):
            rows.append(
                (
                    ja.joint,
                    ja.unit,
                    pair(
                        ja.max_tracking_error,
                        ja.tracking_step,
                        jb.max_tracking_error,
                        jb.tracking_step,
                    ),
                    pair(
                        ja.max_limit_violation,
                        ja.violation_step,
                        jb.max_limit_violation,
                        jb.violation_step,
                    ),
                    pair(
                        ja.max_velocity_ratio,
                        ja.velocity_step,
                        jb.max_velocity_ratio,
                        jb.velocity_step,
                    ),
                )
            )
        rows.append(
            ("peak penetration", "m",
             pair(a.peak_penetration, a.penetration_step, b.peak_penetration,
                  b.penetration_step), ("", ""), ("", ""))
        )  # fmt: skip
        rows.append(
            ("max energy jump", "J",
             pair(a.max_energy_jump, a.energy_step, b.max_energy_jump, b.energy_step),
             ("", ""), ("", ""))
        )  # fmt: skip
        w_name = max(len(header[0]), *(len(r[0]) for r in rows))
        w_unit = max(len(header[1]), *(len(r[1]) for r in rows))
        widths = [
            (max(len(r[i][0]) for r in rows), max(len(r[i][1]) for r in rows)) for i in (2, 3, 4)
        ]

        def both(p: tuple[str, str], w: tuple[int, int]) -> str:
            if not p[0] and not p[1]:
                return " " * (w[0] + 3 + w[1])
            return f"{p[0]:>{w[0]}} | {p[1]:<{w[1]}}"

        heads = [f"{h:^{w[0] + 3 + w[1]}}" for h, w in zip(header[2:], widths, strict=True)]
        lines.append(f"  {header[0]:<{w_name}}  {header[1]:<{w_unit}}  " + "  ".join(heads))
        for r in rows:
            cells = "  ".join(both(p, w) for p, w in zip(r[2:], widths, strict=True))
            lines.append(f"  {r[0]:<{w_name}}  {r[1]:<{w_unit}}  {cells}".rstrip())
        for run in (a, b):
            if run.unstable_at is not None:
                lines.append(f"  {run.label}: UNSTABLE at step {run.unstable_at}")
        if self.contacts_appearing:
            lines.append(f"  contacts only when re-simulated: {', '.join(self.contacts_appearing)}")
        if self.contacts_disappearing:
            lines.append(f"  contacts only when recorded: {', '.join(self.contacts_disappearing)}")
        if self.findings:
            lines.append(
                f"findings: where the re-simulation ({b.control}) differs from the recording "
                f"({a.control}) beyond a threshold, first step of each:"
            )
            lines += [f"  {f.format()}" for f in self.findings]
            lines.append(
                f"VERDICT: DIFFERENT: {len(self.findings)} finding(s); the recorded motion "
                f"does not carry over to {self.actuation} control as it is"
            )
        else:
            lines.append(
                f"VERDICT: SAME BEHAVIOUR: the re-simulation ({self.actuation}) stays within every "
                "threshold of the recording"
            )
        return "\n".join(lines)
