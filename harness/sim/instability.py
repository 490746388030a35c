"""What ends a run: MuJoCo's warnings by name and the message naming the step that failed.

A :class:`~harness.sim.Simulation` checks after every step that no warning counter moved and
that ``data.time`` is ``step * dt``; when either fails, :func:`failure` says what happened
(raised as :class:`~harness.sim.errors.InstabilityError`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from harness.sim.layout import object_name

__all__ = ["failure", "warning_names"]

_WARNING_MEANING = {
    "INERTIA": "invalid inertia",
    "CONTACTFULL": "too many contacts, some dropped",
    "CNSTRFULL": "constraint buffer full, some dropped",
    "BADQPOS": "bad position, MuJoCo auto-reset the state",
    "BADQVEL": "bad velocity, MuJoCo auto-reset the state",
    "BADQACC": "bad acceleration, MuJoCo auto-reset the state",
    "BADCTRL": "bad control value",
}


def warning_names() -> tuple[str, ...]:
    """MuJoCo's warning names by index (``"BADQACC"``, ...), as in ``data.warning``."""
    members = mujoco.mjtWarning.__members__
    by_index = {int(v): k.removeprefix("mjWARN_") for k, v in members.items() if k != "mjNWARNING"}
    return tuple(by_index[i] for i in sorted(by_index))


def failure(model: mujoco.MjModel, data: mujoco.MjData, step: int, dt_ns: int) -> tuple[str, str]:
    """``(message, warning)`` for the failure found after ``step``: the first MuJoCo warning
    counted (with the joint of the dof for BADQACC and BADQVEL), else ``"TIME"`` (simulation
    time does not match ``step * dt``)."""
    nonzero = np.flatnonzero(data.warning.number)
    if nonzero.size:
        index = int(nonzero[0])
        warning = warning_names()[index]
        info = int(data.warning.lastinfo[index])
        where = ""
        if warning in ("BADQACC", "BADQVEL") and 0 <= info < model.nv:
            joint = object_name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[info]))
            where = f" at dof {info} (joint {joint!r})"
        message = (
            f"step {step} (sim time {step * dt_ns} ns): MuJoCo warning {warning}"
            f"{where}: {_WARNING_MEANING.get(warning, 'see MuJoCo docs')}; the run is no "
            "longer valid (lower gains or the timestep, or check masses and forces)"
        )
    else:
        warning = "TIME"
        message = (
            f"step {step}: simulation time {data.time!r} s does not match "
            f"step * dt = {step * dt_ns / 1e9!r} s (time jumped: did MuJoCo reset?)"
        )
    return message, warning
