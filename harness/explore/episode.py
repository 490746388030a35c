"""One example: the concrete scenario of a set of values, run as ``harness run`` runs it.

:class:`EpisodeRunner` writes the example's scenario text (:meth:`ExplorePlan.text`) into its
scratch folder, loads it as ``harness run`` does (:func:`harness.scenario.load_run_file`) and
runs it with the product's iteration runner, plus a :class:`harness.events.ClearanceLogger`
when the plan targets ``min_clearance`` (it emits nothing: the recording is the one
``harness run`` makes). The result is an :class:`Example`: values, verdicts, the failure
signature, the margins and the state digest.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
import shutil
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.events import ClearanceLogger, Logger
from harness.explore.errors import ExploreConfigError
from harness.explore.plan import ExplorePlan
from harness.models import LoadedWorld
from harness.scenario import (
    IterationResult,
    IterationRunner,
    IterationSpec,
    ScenarioError,
    iteration_specs,
    load_run_file,
    session_iteration_runner,
)

__all__ = [
    "CLEARANCE_HZ",
    "EpisodeRunner",
    "Example",
    "clearance_logger",
    "margins_of",
    "signature_of",
]


@dataclass(frozen=True)
class Example:
    """One example run: ``index`` in its engine's order, its ``values``, whether it
    ``passed``, the failure ``signature`` ("" when it passed), ``reason`` (one line), the
    ``margins`` (name -> value), the state ``digest``, and ``kept``: its folder when its
    scenario and recording were kept (failures, a sample of passing examples); ``check``:
    for a kept example of the fast path, ``"identical"`` when the product's run computed
    the same (:mod:`harness.explore.kernel`), else what differed ("" when not checked);
    ``quiet``: its result came from a quiet run (:mod:`harness.explore.quiet`)."""

    worker: int
    index: int
    values: Mapping[str, Any]
    passed: bool
    signature: str
    reason: str
    margins: Mapping[str, float] = field(default_factory=dict)
    digest: str | None = None
    wall_seconds: float = 0.0
    kept: str | None = None
    phase: str = "generate"
    check: str = ""
    quiet: bool = False


def _allowed_pair(a: str, b: str, allowed: tuple[tuple[str, str], ...]) -> bool:
    return any(
        (fnmatch.fnmatchcase(a, pa) and fnmatch.fnmatchcase(b, pb))
        or (fnmatch.fnmatchcase(a, pb) and fnmatch.fnmatchcase(b, pa))
        for pa, pb in allowed
    )


def signature_of(result: IterationResult, allowed: tuple[tuple[str, str], ...] = ()) -> str:
    """What tells one failure from another: each failed verdict's kind and what it is about
    (the first disallowed collision's bodies, the worst joint, the client's status);
    ``allowed``: the scenario's ``allowed_collisions``."""
    if result.error is not None:
        return "error: " + result.error.split(":")[0]
    parts: list[str] = []
    for verdict in result.verdicts:
        if verdict.passed:
            continue
        if verdict.name == "collisions":
            bad = [
                c
                for c in result.collisions
                if not c.world and not c.initial
                if not _allowed_pair(c.body1, c.body2, allowed)
            ] or list(result.collisions)
            first = min(bad, key=lambda c: c.begin) if bad else None
            parts.append(f"collision {first.body1} - {first.body2}" if first else "collision")
        elif verdict.name == "joint_limits":
            worst = max(result.joint_limits, key=lambda j: j.max_excess - j.tolerance)
            parts.append(f"joint limit {worst.joint}")
        elif verdict.name == "client" and result.client is not None:
            code = result.client.exit_code
            parts.append(
                f"client {result.client.status}" + (f" (exit {code})" if code is not None else "")
            )
        else:
            parts.append(verdict.name)
    return "; ".join(parts)


def margins_of(
    result: IterationResult, clearance: ClearanceLogger | None, allowed: tuple[tuple[str, str], ...]
) -> dict[str, float]:
    """The margins of a run: ``min_clearance`` (m, robot to world), ``peak_force`` (N, the
    largest contact force of a robot's contact that began after the start), ``limit_margin``
    (the smallest distance of a joint to its position limit; negative beyond it),
    ``tracking_error`` (the largest |position - command| of a commanded joint)."""
    out: dict[str, float] = {}
    if clearance is not None:
        out["min_clearance"] = clearance.minimum.distance
    forces = [c.peak_force for c in result.collisions if not c.world and not c.initial]
    out["peak_force"] = max(forces, default=0.0)
    margins = [
        min(
            j.min_position - j.lower if j.lower is not None else math.inf,
            j.upper - j.max_position if j.upper is not None else math.inf,
        )
        for j in result.joint_limits
    ]
    finite = [m for m in margins if math.isfinite(m)]
    if finite:
        out["limit_margin"] = min(finite)
    out["tracking_error"] = _tracking_error(result)
    return out


def _tracking_error(result: IterationResult) -> float:
    """The largest |position - command| over the traces' commanded samples (a command NaN:
    none yet), with arrays; a position NaN (a run that blew up) is taken as the plain
    ``max`` over the samples takes it."""
    traces = [t for t in (result.traces.joints if result.traces else ()) if t.command is not None]
    worst = 0.0
    for trace in traces:
        command = np.array(trace.command, dtype=np.float64)
        error = np.abs(np.array(trace.position, dtype=np.float64) - command)
        error = error[~np.isnan(command)]
        if np.isnan(error).any():
            errors = [
                abs(p - c)
                for t in traces
                for p, c in zip(t.position, t.command or (), strict=True)
                if not math.isnan(c)
            ]
            return max(errors, default=0.0)
        if error.size:
            worst = max(worst, float(error.max()))
    return worst


def drive_value(target: str, margins: Mapping[str, float]) -> float | None:
    """The value hypothesis' ``target()`` maximises for ``target`` (toward failure)."""
    if target not in margins:
        return None
    value = margins[target]
    return -value if target in ("min_clearance", "limit_margin") else value


CLEARANCE_HZ = 100.0
"""How often the ``min_clearance`` margin is measured (simulation time): every 5th step at
2 ms; an arm's link moving at 1 m/s moves 1 cm between two measurements."""


def clearance_logger(
    world: LoadedWorld, model: mujoco.MjModel, allowed: tuple[tuple[str, str], ...]
) -> ClearanceLogger:
    """The ``min_clearance`` margin's logger: every robot link (a body of ``model``) against
    the rest of the world, ``allowed`` pairs ignored, distances up to 1 m, measured at
    :data:`CLEARANCE_HZ` of simulation time (a guide for ``target()``: verdicts come from the
    scenario's own loggers, which see every step)."""
    links = [
        view.mujoco_name(link.name) for view in world.robots for link in view.description.links
    ]
    bodies = [b for b in links if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) > 0]
    return ClearanceLogger(
        model, robot_bodies=bodies, ignore=allowed, distmax=1.0, rate_hz=CLEARANCE_HZ
    )


class EpisodeRunner:
    """Runs examples of ``plan`` in ``scratch`` (see the module docstring). ``runner``: the
    iteration runner (default: the product's, :func:`harness.scenario.session_iteration_runner`)."""

    def __init__(
        self,
        plan: ExplorePlan,
        scratch: Path,
        *,
        worker: int = 0,
        runner: IterationRunner | None = None,
    ) -> None:
        self.plan = plan
        self.scratch = scratch
        self.worker = worker
        scratch.mkdir(parents=True, exist_ok=True)
        self._runner = runner if runner is not None else session_iteration_runner()
        self._clearance: list[ClearanceLogger] = []
        self.count = 0

    def _watcher(self, allowed: tuple[tuple[str, str], ...]) -> Callable[[Any], Logger]:
        made = self._clearance

        def watch(session: Any) -> Logger:
            logger = clearance_logger(session.world, session.model, allowed)
            made.append(logger)
            return logger

        return watch

    def run(self, values: Mapping[str, Any], *, keep: Path | None = None) -> Example:
        """Run one example; ``keep``: a folder to copy its scenario and recording to."""
        started = time.monotonic()
        index = self.count
        self.count += 1
        file = self.scratch / "example.yaml"
        file.write_text(self.plan.text(values), encoding="utf-8")
        try:
            config = load_run_file(file)
        except ScenarioError as exc:
            raise ExploreConfigError(
                f"{self.plan.source}: explore: values {dict(values)!r} make the scenario invalid: "
                f"{exc.problems[0]}"
            ) from None
        spec = iteration_specs(config, self.scratch)[0]
        spec = dataclasses.replace(
            spec, out_dir=self.scratch / "run", recording_path=self.scratch / "recording.mcap"
        )
        scenario = spec.scenario
        allowed = tuple(scenario.criteria.allowed_collisions)
        self._clearance.clear()
        runner = self._runner
        if self.plan.target == "min_clearance" and hasattr(runner, "watchers"):
            runner = dataclasses.replace(runner, watchers=(self._watcher(allowed),))  # type: ignore[type-var]
        result = self._run(runner, spec)
        signature = "" if result.passed else signature_of(result, allowed)
        margins = margins_of(result, self._clearance[0] if self._clearance else None, allowed)
        kept = None
        if keep is not None:
            keep.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(file, keep / "scenario.yaml")
            if spec.recording_path.is_file():
                shutil.copyfile(spec.recording_path, keep / "recording.mcap")
            kept = str(keep)
        return Example(
            worker=self.worker,
            index=index,
            values=dict(values),
            passed=result.passed,
            signature=signature,
            reason=result.reason or "",
            margins=margins,
            digest=result.state_digest,
            wall_seconds=time.monotonic() - started,
            kept=kept,
        )

    @staticmethod
    def _run(runner: IterationRunner, spec: IterationSpec) -> IterationResult:
        try:
            return runner(spec)
        except ScenarioError as exc:
            raise ExploreConfigError(str(exc).splitlines()[0]) from None
        except Exception as exc:  # a failure of the example, not of the search
            return IterationResult(
                simulation=spec.simulation,
                iteration=spec.iteration,
                verdicts=(),
                sim_time=0.0,
                steps=0,
                error=f"{type(exc).__name__}: {exc}",
            )
