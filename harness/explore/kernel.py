"""The generation kernel: an example of a scenario without a client program, run on a
:class:`harness.session.SessionCore` directly.

``harness run`` runs an iteration in a :class:`harness.session.Session`: a world loaded and
compiled, a recorder, a WebSocket server and a loop thread, each step handed to that thread.
An example that no client drives needs none of that shell: :func:`run_core` drives the
sans-I/O core itself, as the session's loop would (start, the initial publication, the
``script`` commands at their step boundaries, every step, the close and the loggers'
finish), with the scenario's loggers and sinks and the same observer, and computes the
verdicts, collisions, joint limits, traces and state digest as the session runner does
(the pieces of :mod:`harness.scenario`). Nothing is recorded: the recording is what the
search does not need, until an example is kept.

:class:`KernelRunner` is the fast path's example runner: the world comes warm
(:mod:`harness.explore.warm`), the kernel runs the example. A scenario with a client program
(or a ``resume`` section) goes the product's way (:class:`~harness.explore.episode.EpisodeRunner`).

No shortcut: a kept example (every failure, the sample of passing ones) is run a second
time through the product's path with the recorder on (its recording is the one ``harness
run`` makes), and what the kernel computed must be what the product computed: the verdict,
the signature, the margins, the state digest, and the compiled model (the recording's
``model.mjb`` attachment against the warm world's). A difference is a
:attr:`KernelRunner.mismatches` entry: the search reports it as an error
(:func:`harness.explore.search.search`), it is never hidden.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from harness.events import (
    ClearanceLogger,
    CollectingSink,
    Event,
    EventHub,
    Level,
    StepContext,
)
from harness.explore.core import (
    TRACE_SAMPLES,
    CoreTarget,
    core_options,
    example_observer,
    example_result,
)
from harness.explore.episode import (
    EpisodeRunner,
    Example,
    clearance_logger,
    margins_of,
    signature_of,
)
from harness.explore.errors import ExploreConfigError
from harness.explore.fast import FastRunner
from harness.explore.plan import ExplorePlan
from harness.explore.quiet import quiet_blocker, quiet_run
from harness.explore.warm import WarmWorlds, model_bytes, topology_key
from harness.models import LoadedWorld
from harness.scenario import (
    IterationResult,
    Scenario,
    ScenarioError,
    ScenarioSession,
    check_script,
    collision_summaries,
    robot_links,
    run_script,
    run_verdicts,
    sink_notes,
    steps_for,
)
from harness.session import SessionCore, SessionError

__all__ = ["QUIET_CHECKS", "TRACE_SAMPLES", "KernelRunner", "run_core"]

QUIET_CHECKS = 2
"""How many quiet passes of each topology are also run in full and compared."""


class _CoreTarget(CoreTarget):
    """A :class:`harness.scenario.ScriptCommand` target over a core: what
    :meth:`harness.session.Session.step` and its Python commands do, without the shell (no
    frames wait at a boundary: nothing is connected)."""

    def step(self, n: int = 1) -> int:
        core = self._core
        if core.clock != "lockstep" and not core.paused:
            raise SessionError(f"the clock is {core.clock}: time moves by itself")
        for _ in range(n):
            core.check_running()
            core.advance()
        return core.sim.step_index


class _Kept:
    """The ``min_clearance`` logger on the hub, its steps measured at the end
    (:meth:`harness.events.ClearanceLogger.keep`: the same minimum, in one pass)."""

    def __init__(self, margin: ClearanceLogger) -> None:
        self._margin = margin
        self.name = margin.name
        self.period_ns = margin.period_ns

    def observe(self, ctx: StepContext) -> list[Event]:
        self._margin.keep(ctx)
        return []

    def finish(self, ctx: StepContext) -> list[Event]:
        return []


def run_core(
    scenario: Scenario,
    planned: ScenarioSession,
    world: LoadedWorld,
    timestep: float,
    clearance: tuple[tuple[str, str], ...] | None = None,
) -> tuple[IterationResult, ClearanceLogger | None]:
    """Run ``scenario`` (no client program) on a core of ``world`` (``planned``: its session
    plan; ``timestep``: its step) as the session runner runs it, recording nothing; with
    ``clearance`` (the allowed pairs), a ``min_clearance`` logger too. Raises what the session
    runner raises (a bad ``script`` joint: :class:`harness.scenario.ScenarioError`)."""
    started = time.monotonic()
    options = core_options(scenario, planned)
    hub = EventHub()
    core = SessionCore(world, options, hub=hub)
    collect = CollectingSink(min_level=Level.INFO)
    for sink in [*planned.sinks(), collect]:
        hub.add_sink(sink)
    sim = core.sim
    obs = example_observer(scenario, core, world, timestep)
    hub.add_logger(obs)
    margin: ClearanceLogger | None = None
    stepper_error: BaseException | None = None
    dt_ns = core.dt_ns
    try:
        core.start()
        core.publish_initial()
        for logger in planned.loggers(world):
            hub.add_logger(logger)
        if clearance is not None:
            margin = clearance_logger(world, sim.model, clearance)
            hub.add_logger(_Kept(margin))
        limit = steps_for(scenario.duration, dt_ns)
        target = _CoreTarget(core)
        try:
            if scenario.script:
                check_script(scenario, sim.joint_names)
                run_script(target, scenario.script, dt_ns, limit, limit + 1)
            elif core.clock == "lockstep":
                target.step(max(0, limit - target.step_index))
            else:  # a free-running clock runs to its pause at the limit
                core.set_paused(False)
                while sim.step_index < limit and core.failure is None:
                    try:
                        core.advance()
                    except Exception:  # the core's failure: a free clock's driver keeps it
                        break  # and the verdict names it
        except SessionError as exc:
            stepper_error = exc
        failure = core.failure
    finally:
        core.record_close()
        reports = core.finish()
    if margin is not None:
        margin.settle(sim.model, sim.data)
    collisions = collision_summaries(
        collect.events, dt_ns, robot_links(world), obs.first, sim.model
    )
    limits = obs.limits()
    problem = failure or stepper_error
    verdicts = run_verdicts(scenario, None, collisions, limits, obs, sim.data, problem)
    notes = sink_notes(reports)
    result = example_result(
        scenario, obs, world, dt_ns, verdicts, collisions, limits, notes, started
    )
    return result, margin


def _recorded_model(recording: Path) -> bytes | None:
    from harness.recording import Recording

    if not recording.is_file():
        return None
    with Recording(recording) as rec:
        return rec.attachment("model.mjb")


class KernelRunner(EpisodeRunner):
    """The fast path's example runner (see the module docstring): warm worlds
    (:attr:`worlds`), the kernel for examples without a client program, the product's
    runner (whole spans per step request, :class:`harness.explore.fast.FastRunner`) for the
    others and for kept examples. ``mismatches``: kept examples whose kernel result differed
    from the product's, one line each."""

    def __init__(
        self, plan: ExplorePlan, scratch: Path, *, worker: int = 0, quiet: bool = True
    ) -> None:
        super().__init__(plan, scratch, worker=worker, runner=FastRunner())
        self.worlds = WarmWorlds(scratch / "worlds")
        self.mismatches: list[str] = []
        self.kernel_runs = 0
        self.quiet = quiet
        """Whether passing examples may run quiet (:mod:`harness.explore.quiet`)."""
        self.quiet_runs = 0
        """Examples whose result came from a quiet run."""
        self._quiet_checked: dict[str, int] = {}
        self._failed = False  # the last example failed: the next likely does too (shrinking)

    def run(self, values: Mapping[str, Any], *, keep: Path | None = None) -> Example:
        """Run one example (see the class docstring); ``keep``: a folder for its scenario
        and recording (the product's run, checked against the kernel's)."""
        started = time.monotonic()
        plan = self.plan
        try:
            document, scenario = plan.concrete(values)
        except ScenarioError as exc:
            raise ExploreConfigError(
                f"{plan.source}: explore: values {dict(values)!r} make the scenario invalid: "
                f"{exc.problems[0]}"
            ) from None
        if scenario.client is not None or scenario.resume is not None:
            return super().run(values, keep=keep)
        index = self.count
        self.count += 1
        allowed = tuple(scenario.criteria.allowed_collisions)
        wants_clearance = plan.target == "min_clearance"
        world: LoadedWorld | None = None
        quiet = False
        try:
            planned, world, timestep = self.worlds.get(scenario, document)
            clearance = allowed if wants_clearance else None
            outcome = self._quiet(document, scenario, planned, world, timestep, clearance)
            if outcome is None:
                outcome = run_core(scenario, planned, world, timestep, clearance), False
            (result, margin), quiet = outcome
        except ScenarioError as exc:
            raise ExploreConfigError(str(exc).splitlines()[0]) from None
        except Exception as exc:  # a failure of the example, not of the search
            result, margin = _error_result(scenario, exc), None
        self.kernel_runs += 1
        self._failed = not result.passed
        self.mismatches += [f"example {dict(values)!r}: {note}" for note in self.worlds.notes]
        self.worlds.notes.clear()
        example = Example(
            worker=self.worker,
            index=index,
            values=dict(values),
            passed=result.passed,
            signature="" if result.passed else signature_of(result, allowed),
            reason=result.reason or "",
            margins=margins_of(result, margin, allowed),
            digest=result.state_digest,
            wall_seconds=time.monotonic() - started,
            quiet=quiet,
        )
        if keep is None:
            return example
        product = super().run(values, keep=keep)
        self.count = index + 1
        problems = _differences(example, product)
        if product.kept is not None and world is not None:
            recorded = _recorded_model(Path(product.kept) / "recording.mcap")
            if recorded is not None and recorded != model_bytes(world.model):
                problems.append("compiled model (the recording's model.mjb)")
        if problems:
            self.mismatches.append(
                f"example {dict(values)!r}: the fast path and harness run differ in "
                + ", ".join(problems)
            )
        return dataclasses.replace(
            example,
            kept=product.kept,
            wall_seconds=time.monotonic() - started,
            check="differs: " + ", ".join(problems) if problems else "identical",
        )

    def _quiet(
        self,
        document: Mapping[str, Any],
        scenario: Scenario,
        planned: ScenarioSession,
        world: LoadedWorld,
        timestep: float,
        clearance: tuple[tuple[str, str], ...] | None,
    ) -> tuple[tuple[IterationResult, ClearanceLogger | None], bool] | None:
        """A quiet run's pass and True, or None (the example runs in full; so does the
        example after a failure, without a quiet try: while a failure is shrunk most
        examples fail, and a quiet run that ends at a contact is time lost). The first
        :data:`QUIET_CHECKS` quiet passes of a topology also run in full: a difference is a
        :attr:`mismatches` entry and that topology runs in full from then on."""
        if self._failed or not self.quiet or quiet_blocker(scenario, planned) is not None:
            return None
        key = topology_key(document)
        checked = self._quiet_checked.get(key, 0)
        if checked < 0:
            return None
        outcome = quiet_run(scenario, planned, world, timestep, clearance)
        if outcome is None:
            return None
        self.quiet_runs += 1
        if checked >= QUIET_CHECKS:
            return outcome, True
        full = run_core(scenario, planned, world, timestep, clearance)
        allowed = tuple(scenario.criteria.allowed_collisions)
        seen, expected = _outcome(*outcome, allowed), _outcome(*full, allowed)
        if seen == expected:
            self._quiet_checked[key] = checked + 1
            return outcome, True
        self._quiet_checked[key] = -1
        self.mismatches.append(
            f"a quiet run and the full run differ ({seen} vs {expected}); that world now "
            "runs every example in full"
        )
        return full, False


def _outcome(
    result: IterationResult, margin: ClearanceLogger | None, allowed: tuple[tuple[str, str], ...]
) -> tuple[Any, ...]:
    """What an :class:`~harness.explore.episode.Example` takes from a run."""
    return (
        result.passed,
        signature_of(result, allowed) if not result.passed else "",
        result.reason or "",
        margins_of(result, margin, allowed),
        result.state_digest,
    )


def _differences(fast: Example, product: Example) -> list[str]:
    """What differs between the kernel's and the product's run of one example."""
    out = []
    if fast.passed != product.passed:
        out.append(f"verdict ({fast.passed} vs {product.passed})")
    if fast.signature != product.signature:
        out.append(f"signature ({fast.signature!r} vs {product.signature!r})")
    if fast.digest != product.digest:
        out.append("state digest")
    if dict(fast.margins) != dict(product.margins):
        out.append(f"margins ({dict(fast.margins)} vs {dict(product.margins)})")
    return out


def _error_result(scenario: Scenario, exc: Exception) -> IterationResult:
    return IterationResult(
        simulation=scenario.name,
        iteration=1,
        verdicts=(),
        sim_time=0.0,
        steps=0,
        error=f"{type(exc).__name__}: {exc}",
    )
