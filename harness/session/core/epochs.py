"""A reset of a running simulation, and the epoch record that marks it in the recording.

A reset (``/harness/reset``, :meth:`~harness.session.core.SessionCore.reset`) puts the
simulation back to its initial state without restarting the step numbering
(:func:`restart`): the physics state recorded for the current step ends one epoch, and an
:class:`~harness.recording.records.Epoch` record (:func:`reset_epoch`, ``harness_msgs/Epoch``)
holds the state the next one starts from. The core keeps the epoch count and clears its own
state (commands, controllers, failure).
"""

from __future__ import annotations

from harness.recording import Epoch
from harness.sim import Simulation

__all__ = ["reset_epoch", "restart"]


def restart(sim: Simulation) -> int:
    """Put ``sim`` back to its initial state at its current step (the step numbering and the
    simulation time continue from there); returns that step."""
    k = sim.step_index
    sim.reset()
    state = sim.get_state()
    state[0] = k * sim.dt_ns / 1e9  # mjSTATE_TIME first: step numbering continues
    sim.set_state(state, k)
    return k


def reset_epoch(sim: Simulation, epoch: int) -> Epoch:
    """The record of epoch number ``epoch`` starting at ``sim``'s current step and state
    (its arrays are the simulation's own: valid until the next step)."""
    return Epoch(
        step=sim.step_index,
        sim_time_ns=sim.sim_time_ns,
        epoch=epoch,
        reason="reset",
        state_spec=sim.state_spec,
        state=sim.get_state(),
        qpos=sim.data.qpos,
        qvel=sim.data.qvel,
    )
