"""The physics input applied at a step, and the one function that applies it.

:class:`AppliedInput` mirrors ``harness_msgs/msg/AppliedInput`` (defined in :mod:`harness.applied`,
which a recording's reader imports without MuJoCo). :func:`advance` is the single
definition of "apply this input, take one step": :class:`~harness.sim.Simulation` steps through
it and replay uses it, so a recording's inputs mean exactly what the live run did. Physics
replay needs only the model, the initial state and the inputs (:func:`replay`).

Step numbering: the input with ``step == k`` is applied to the state after step ``k - 1`` and
produces the state after step ``k`` (``sim_time_ns == k * dt_ns``); the initial state is step 0.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import mujoco
import numpy as np
import numpy.typing as npt

from harness.applied import ARRAY_FIELDS, AppliedInput
from harness.sim.errors import StateError

__all__ = ["ARRAY_FIELDS", "AppliedInput", "advance", "replay", "write_input"]

F64 = npt.NDArray[np.float64]


def write_input(model: mujoco.MjModel, data: mujoco.MjData, inp: AppliedInput) -> None:
    """Write ``inp``'s ctrl, mocap poses and applied forces into ``data`` (what :func:`advance`
    writes before the step, kinematic qpos/qvel writes apart)."""
    data.ctrl[:] = inp.ctrl
    if inp.mocap_pos.size:
        data.mocap_pos[:] = inp.mocap_pos.reshape(model.nmocap, 3)
        data.mocap_quat[:] = inp.mocap_quat.reshape(model.nmocap, 4)
    if inp.qfrc_applied.size:
        data.qfrc_applied[:] = inp.qfrc_applied
    else:
        data.qfrc_applied[:] = 0.0
    if inp.xfrc_applied.size:
        data.xfrc_applied[:] = inp.xfrc_applied.reshape(model.nbody, 6)
    else:
        data.xfrc_applied[:] = 0.0


def advance(model: mujoco.MjModel, data: mujoco.MjData, inp: AppliedInput) -> None:
    """Apply ``inp`` to ``data`` and take one ``mj_step``, exactly as the live run did.

    No stability checks: :class:`~harness.sim.Simulation` adds them around its own loop.
    """
    write_input(model, data, inp)
    if inp.qpos_index.size:
        data.qpos[inp.qpos_index] = inp.qpos_value
        data.qvel[inp.qvel_index] = inp.qvel_value
    mujoco.mj_step(model, data)
    if inp.qpos_index.size:
        data.qpos[inp.qpos_index] = inp.qpos_value
        data.qvel[inp.qvel_index] = inp.qvel_value


def replay(
    model: mujoco.MjModel,
    initial_state: F64,
    inputs: Iterable[AppliedInput],
    *,
    end_step: int | None = None,
    state_spec: int = int(mujoco.mjtState.mjSTATE_INTEGRATION),
) -> Iterator[tuple[int, F64]]:
    """Re-simulate from ``initial_state`` (the state just before the first input's step) and
    yield ``(step, state)`` after every step.

    ``inputs`` (in step order) may hold only the steps where the input changed: each holds
    until the next. The run ends at ``end_step`` (default: the last input's step).
    """
    queue = list(inputs)
    if not queue:
        return
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, np.asarray(initial_state, dtype=np.float64), state_spec)
    size = mujoco.mj_stateSize(model, state_spec)
    last = queue[-1].step if end_step is None else end_step
    current = queue[0]
    index = 0
    for step in range(queue[0].step, last + 1):
        if index < len(queue):
            if queue[index].step < step:
                raise StateError(
                    f"applied inputs out of order: step {queue[index].step} after step {step - 1}"
                )
            if queue[index].step == step:
                current = queue[index]
                index += 1
        advance(model, data, current)
        state = np.empty(size, dtype=np.float64)
        mujoco.mj_getState(model, data, state, state_spec)
        yield step, state
