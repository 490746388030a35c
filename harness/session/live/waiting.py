"""Stepping from Python on the session's event loop: :meth:`Session.step
<harness.session.Session.step>` (:func:`run_steps`, refused while a free-running clock runs)
and :meth:`Session.run_until <harness.session.Session.run_until>`: in lockstep it steps until
the predicate holds (:func:`run_until_lockstep`); with a free-running clock it registers a
watcher the driver calls after each step (:func:`run_until_free`). Both give up after a budget
of steps of simulation time (:func:`sim_timeout_error`).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from harness.session.core.engine import SessionCore
from harness.session.errors import SessionError, SimTimeoutError
from harness.sim import Simulation

__all__ = [
    "require_stepping",
    "run_steps",
    "run_until_free",
    "run_until_lockstep",
    "sim_timeout_error",
]


def require_stepping(core: SessionCore, clock: str) -> None:
    """Refuse stepping while a free-running ``clock`` runs, or after a failure."""
    if clock != "lockstep" and not core.paused:
        raise SessionError(
            f"the clock is {clock}: time moves by itself; pause() first to step, or "
            "wait with run_until()"
        )
    core.check_running()


async def run_steps(
    core: SessionCore,
    clock: str,
    n: int,
    boundary: Callable[[], None],
    settled_advance: Callable[[], None],
) -> int:
    """Take ``n`` steps (``boundary`` then ``settled_advance``, the session's step), yielding
    to the loop between them; the step index reached."""
    require_stepping(core, clock)
    for i in range(n):
        boundary()
        core.check_running()
        settled_advance()
        if i + 1 < n:
            await asyncio.sleep(0)
    return core.sim.step_index


def sim_timeout_error(sim: Simulation, sim_timeout: float) -> SimTimeoutError:
    """The error of a ``run_until`` whose ``sim_timeout`` passed, naming where ``sim`` is."""
    t = sim.sim_time_ns
    return SimTimeoutError(
        f"condition not met within {sim_timeout:g} s of simulation time "
        f"(now step {sim.step_index}, sim time {t / 1e9:.6f} s)"
    )


async def run_until_lockstep(
    core: SessionCore,
    predicate: Callable[[], bool],
    budget: int,
    sim_timeout: float,
    boundary: Callable[[], None],
    settled_advance: Callable[[], None],
) -> int:
    """Step (``boundary`` then ``settled_advance``, the session's step) until ``predicate()``
    holds, at most ``budget`` steps; the step at which it held."""
    sim = core.sim
    core.check_running()
    for i in range(budget + 1):
        if predicate():
            return sim.step_index
        if i == budget:
            break
        boundary()
        core.check_running()
        settled_advance()
        await asyncio.sleep(0)
    raise sim_timeout_error(sim, sim_timeout)


async def run_until_free(
    core: SessionCore,
    watchers: list[Callable[[], None]],
    predicate: Callable[[], bool],
    budget: int,
    sim_timeout: float,
) -> int:
    """Wait until ``predicate()`` holds, checked by a watcher in ``watchers`` (called after
    every step of a free-running clock) for at most ``budget`` steps; the step at which it
    held."""
    sim = core.sim
    core.check_running()
    if predicate():
        return sim.step_index
    done: asyncio.Future[int] = asyncio.get_running_loop().create_future()
    deadline = sim.step_index + budget

    def check() -> None:
        if done.done():
            return
        try:
            core.check_running()
            if predicate():
                done.set_result(sim.step_index)
            elif sim.step_index >= deadline:
                done.set_exception(sim_timeout_error(sim, sim_timeout))
        except Exception as exc:
            done.set_exception(exc)

    watchers.append(check)
    try:
        return await done
    finally:
        watchers.remove(check)
