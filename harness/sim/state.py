"""Captured simulation states: the ``mjtState`` mask every state uses (:data:`STATE_SPEC`) and
the checks a state passes before a :class:`~harness.sim.Simulation` restores it."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.errors import StateError

__all__ = ["STATE_SPEC", "checked_state", "out_error", "qpos_qvel_slices"]

STATE_SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
"""The ``mjtState`` mask of every captured state: FULLPHYSICS alone misses the solver
warmstart and does not restore bit-exactly."""


def checked_state(
    state: npt.ArrayLike, size: int, step_index: int, dt: float, dt_ns: int
) -> npt.NDArray[np.float64]:
    """``state`` as a float64 array, checked to be a state of ``size`` finite values whose time
    is ``step_index * dt`` (within half a step); raises :class:`StateError` otherwise."""
    arr = np.asarray(state, dtype=np.float64)
    if arr.shape != (size,):
        raise StateError(
            f"state has shape {arr.shape}, the model's INTEGRATION state has ({size},)"
        )
    if not np.all(np.isfinite(arr)):
        raise StateError("state holds non-finite values")
    if step_index < 0:
        raise StateError(f"step_index must be >= 0, not {step_index}")
    # mjSTATE_TIME is the first component of every state.
    if abs(float(arr[0]) - step_index * dt) > dt / 2:
        raise StateError(
            f"state time {float(arr[0])!r} s does not match step {step_index} "
            f"(step * dt = {step_index * dt_ns / 1e9!r} s)"
        )
    return arr


def out_error(out: object, size: int) -> StateError:
    """The error of a ``get_state(out=)`` array MuJoCo cannot write ``size`` values into."""
    return StateError(
        f"get_state(out=): out must be a writable C-contiguous float64 array of "
        f"{size} values, not {getattr(out, 'dtype', type(out).__name__)} "
        f"of shape {getattr(out, 'shape', '?')}"
    )


def qpos_qvel_slices(model: mujoco.MjModel) -> tuple[slice, slice]:
    """Where ``qpos`` and ``qvel`` lie in a :data:`STATE_SPEC` state of ``model`` (a state
    lists its components in the order of their ``mjtState`` bits)."""
    before_qpos = mujoco.mj_stateSize(model, STATE_SPEC & (int(mujoco.mjtState.mjSTATE_QPOS) - 1))
    before_qvel = mujoco.mj_stateSize(model, STATE_SPEC & (int(mujoco.mjtState.mjSTATE_QVEL) - 1))
    return (
        slice(before_qpos, before_qpos + model.nq),
        slice(before_qvel, before_qvel + model.nv),
    )
