"""The quiet run: a passing example's result without the loggers' work at every step.

Most examples a search generates pass, and in a passing run of a scripted scenario nothing
the verdicts read happens at most steps: no robot touches anything, no sink listens, no
client waits. :func:`quiet_run` runs such an example on a :class:`harness.session.SessionCore`
as :func:`harness.explore.kernel.run_core` does (the same start, script commands at their step
boundaries, controller updates and ``mj_step``; not the initial publication of latched
messages, for subscribers there are none of), but at each step it
only keeps MuJoCo's state (one ``mj_getState`` row) and looks at the contacts' geom pairs
(each distinct set classified once); the observer's digest, joint ranges and limit counts
come from those rows in one pass at the end (:meth:`harness.scenario.IterationObserver.absorb`),
its trace samples are taken at their steps, and the ``min_clearance`` margin's geom poses at
the steps the session's hub would measure them, all measured in one pass at the end
(:meth:`harness.events.ClearanceLogger.keep`).

It answers only for a run that passes:

- the first step with a contact that could be judged (a robot's geom in it; any contact
  when ``criteria.world_collisions`` judges world objects' contacts too) ends it, as does a
  failure of the simulation or of a script command, and a failed verdict: the caller runs the
  example in full (:func:`~harness.explore.kernel.run_core`), whose loggers say what happened;
- what it does not cover is never quiet (:func:`quiet_blocker`): sensors (their schedules run
  at the step), ``logging`` destinations (they receive every logger's events), a
  ``returns_to_start`` criterion, a clock that is not ``lockstep``.

A run without a judged contact has no collision the verdicts or margins read (a contact
between world objects only is recorded by the collision logger and not judged; its force is
not a margin), so its verdicts are the joint limits' (the observer's, as in the full run) and
its margins those of :func:`harness.explore.episode.margins_of` with no collisions. Checked,
not assumed: :class:`~harness.explore.kernel.KernelRunner` runs the first quiet passes of each
topology in full as well and compares the examples.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events import ClearanceLogger, EventHub, StepContext
from harness.explore.core import CoreTarget, core_options, example_observer, example_result
from harness.explore.episode import clearance_logger
from harness.models import LoadedWorld
from harness.scenario import (
    IterationResult,
    Scenario,
    ScenarioError,
    ScenarioSession,
    check_script,
    robot_links,
    run_script,
    run_verdicts,
    steps_for,
)
from harness.session import SessionCore
from harness.sim import ContactSet

__all__ = ["quiet_blocker", "quiet_run"]


def quiet_blocker(scenario: Scenario, planned: ScenarioSession) -> str | None:
    """Why ``scenario`` cannot run quiet (None: it can; see the module docstring)."""
    if scenario.client is not None or scenario.resume is not None:
        return "a client program or a resume section"
    if scenario.sensors:
        return "sensors"
    if scenario.logging.enable and scenario.logging.destinations:
        return "logging destinations"
    if scenario.criteria.returns_to_start is not None:
        return "a returns_to_start criterion"
    if planned.options.clock != "lockstep":
        return f"a {planned.options.clock} clock"
    return None


class _Judged(Exception):
    """A step had a contact the verdicts could judge: the quiet run stops."""


class _Moved(Exception):
    """The contacts were not where their view looked: the quiet run stops."""


class _QuietTarget(CoreTarget):
    """A :class:`harness.scenario.ScriptCommand` target that steps a core quietly (see the
    module docstring)."""

    def __init__(
        self,
        core: SessionCore,
        world: LoadedWorld,
        rows: npt.NDArray[np.float64],
        every: int,
        judge_world: bool,
        margin: ClearanceLogger | None,
    ) -> None:
        super().__init__(core)
        sim = core.sim
        model = sim.model
        self.samples: list[tuple[int, int, npt.NDArray[np.float64]]] = []
        """The observer's trace samples: row, simulation time, the joints' commands."""
        self._rows = list(rows)  # one view per step, made once
        self._first = sim.step_index + 1
        self._every = every
        self._spec = sim.state_spec
        robot = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in robot_links(world)}
        robot.discard(-1)
        judged = np.isin(np.asarray(model.geom_bodyid), sorted(robot))
        self._judged = np.ones(model.ngeom, dtype=bool) if judge_world else judged
        self._clean: set[bytes] = {b""}
        self._last = b""
        self._margin = margin
        self._margin_period = margin.period_ns if margin is not None else 0
        self._margin_due = 0  # the hub's next due time (EventHub.observe)
        self._robot = core.robot_name
        self._no_contacts = ContactSet.empty()
        self._contacts_at: int | None = None

    def step(self, n: int = 1) -> int:
        core = self._core
        sim = core.sim
        model, data = sim.model, sim.data
        control = core.control
        before, quiet_until = control.before_step, control.quiet_until
        advance, mj_step, get_state = sim.step, mujoco.mj_step, mujoco.mj_getState
        rows, first, spec = self._rows, self._first, self._spec
        clean, last = self._clean, self._last
        seen = 0  # the number of contacts ``geoms`` views
        geoms = np.zeros((0, 2), dtype=np.int32)
        margin, period, every = self._margin, self._margin_period, self._every
        dt_ns = sim.dt_ns
        k = sim.step_index
        busy = quiet_until(k)  # a command may have come since the last step
        commands = sim.joint_commands()  # changed only by a command or a controller
        samples = self.samples
        plain = 0  # bare mj_step calls not yet told to the simulation
        try:
            for _ in range(n):
                if k >= busy:  # what SessionCore.advance does before the step, when it does
                    if plain:
                        sim.stepped(plain)
                        plain = 0
                    before()
                    busy = quiet_until(k + 1)
                    commands = sim.joint_commands()
                if sim.plain:
                    mj_step(model, data)
                    plain += 1
                else:
                    if plain:
                        sim.stepped(plain)
                        plain = 0
                    advance()
                k += 1
                get_state(model, data, rows[k - first], spec)  # a list's item: no new view
                ncon = data.ncon
                if ncon:
                    if ncon != seen:
                        geoms, seen = self._contact_geoms(data), ncon
                    key = geoms.tobytes()
                    if key != last:
                        if key not in clean:
                            pairs = np.frombuffer(key, dtype=np.int32)
                            if self._judged[pairs].any():
                                raise _Judged(k)
                            clean.add(key)
                        last = key
                elif last:
                    last = b""
                if margin is not None:
                    t = k * dt_ns
                    if t >= self._margin_due:
                        self._margin_due = (t // period + 1) * period
                        context = StepContext(k, t, model, data, self._no_contacts, self._robot)
                        margin.keep(context)
                if k % every == 0:
                    samples.append((k - first, k * dt_ns, commands))
        finally:
            if plain:
                sim.stepped(plain)
        if seen and data.ncon == seen and geoms.tobytes() != data.contact.geom.tobytes():
            raise _Moved  # the view was not the live contacts (checked once a call)
        self._last = last
        return k

    def _contact_geoms(self, data: mujoco.MjData) -> npt.NDArray[np.int32]:
        """The contacts' geom ids, a view that stays the live one while their number does:
        MuJoCo keeps the contacts at the start of its arena (checked: a view at another
        address, or one that differs from the contacts, ends the quiet run)."""
        geoms: npt.NDArray[np.int32] = data.contact.geom
        address = geoms.__array_interface__["data"][0]
        if self._contacts_at is None:
            self._contacts_at = address
        elif address != self._contacts_at:
            raise _Moved
        return geoms


def quiet_run(
    scenario: Scenario,
    planned: ScenarioSession,
    world: LoadedWorld,
    timestep: float,
    clearance: tuple[tuple[str, str], ...] | None = None,
) -> tuple[IterationResult, ClearanceLogger | None] | None:
    """Run ``scenario`` quietly (see the module docstring); the result and the margin's
    logger of a passing run, None when the run is not a quiet pass (the caller runs it in
    full). ``scenario`` must have no :func:`quiet_blocker`. Arguments: those of
    :func:`harness.explore.kernel.run_core`."""
    started = time.monotonic()
    core = SessionCore(world, core_options(scenario, planned), hub=EventHub())
    sim = core.sim
    observer = example_observer(scenario, core, world, timestep)
    every = observer.every
    dt_ns = core.dt_ns
    try:
        core.start()
        # no publish_initial(): it latches the robots' descriptions and static transforms
        # for subscribers and records step 0, and a quiet run has neither
        margin = None if clearance is None else clearance_logger(world, sim.model, clearance)
        limit = steps_for(scenario.duration, dt_ns)
        first = sim.step_index
        rows = np.empty((max(0, limit - first), sim.state_size))
        target = _QuietTarget(core, world, rows, every, scenario.criteria.world_collisions, margin)
        try:
            if scenario.script:
                check_script(scenario, sim.joint_names)
                run_script(target, scenario.script, dt_ns, limit, limit + 1)
            else:
                target.step(max(0, limit - first))
        except (_Judged, _Moved):
            return None
        except ScenarioError:
            raise
        except Exception:  # the full run fails the same way and says how
            return None
        steps = sim.step_index - first
        observer.absorb(rows[:steps], sim.step_index, target.samples)
        if margin is not None:
            margin.settle(sim.model, sim.data)
    finally:
        core.record_close()
        core.finish()
    limits = observer.limits()
    verdicts = run_verdicts(scenario, None, (), limits, observer, sim.data, None)
    if not all(v.passed for v in verdicts):
        return None
    result = example_result(scenario, observer, world, dt_ns, verdicts, (), limits, (), started)
    return result, margin
