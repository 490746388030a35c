"""The kinematic fast path (issue 20): a simulation whose only new input since the last step is
kinematic positions steps through a lean path; it must give bit for bit what the general path
gives (an observer forces the general one), and the applied inputs it reports must be copies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.models import load_robot
from harness.sim import Simulation
from harness.sim.inputs import ARRAY_FIELDS

# Every arm joint and the fingers kinematic (consecutive addresses, a mimic follower), and a mix
# whose kinematic joints are not consecutive (dynamic joints between them).
CONTROLS = {
    "all kinematic": "kinematic",
    "mixed": {
        "joint1": "kinematic",
        "joint2": "position",
        "joint3": "kinematic",
        "joint4": "velocity",
        "joint5": "kinematic",
        "finger_joint1": "kinematic",
    },
}


def _drive(sim: Simulation, step: int, start: list[float]) -> list[object]:
    """The command of ``step``: new positions most steps, holds, a repeated command, every
    joint (ignored fields included), a dynamic command and a wrench now and then; returns the
    notices."""
    names = sim.joint_names
    offset = 0.3 * math.sin(step * 0.05)
    notices: list[object] = []
    if step % 40 >= 30:
        return notices  # hold: positions settle, the velocity drops to zero
    if step % 40 == 20:
        notices += sim.set_positions(dict(zip(names, start, strict=True)))  # same values again
    elif step % 50 == 7:
        jump = 4.0 if all(m == "kinematic" for m in sim.control.values()) else 0.05  # clamps
        notices += sim.set_positions({n: q + jump for n, q in zip(names, start, strict=True)})
    else:
        kinematic = [n for n in names if sim.control[n] == "kinematic"]
        notices += sim.set_positions({n: start[names.index(n)] + offset for n in kinematic})
    if step % 60 == 11 and "joint4" in names and sim.control["joint4"] == "velocity":
        notices += sim.set_velocities({"joint4": 0.1 * offset})
    if step == 90:
        sim.apply_wrench(sim.body_name(sim.model.nbody - 1), [0.0, 0.0, 2.0])
    return notices


@pytest.mark.parametrize("control", list(CONTROLS.values()), ids=list(CONTROLS))
def test_the_fast_path_steps_exactly_as_the_general_path(control):
    robot = load_robot("demo", control=control)
    fast, general = Simulation(robot), Simulation(robot)
    general.add_observer(lambda sim: None)  # an observer takes the general path every step
    start = fast.joint_positions().tolist()
    changed = 0
    for k in range(200):
        assert repr(_drive(fast, k, start)) == repr(_drive(general, k, start))
        fast.step()
        general.step()
        assert fast.get_state().tobytes() == general.get_state().tobytes(), f"step {k + 1}"
        assert fast.input_changed == general.input_changed, f"step {k + 1}"
        changed += fast.input_changed
        a, b = fast.last_input, general.last_input
        assert a is not None
        assert b is not None
        assert (a.step, a.sim_time_ns, a.kinematic_joints) == (
            b.step,
            b.sim_time_ns,
            b.kinematic_joints,
        )
        for field in ARRAY_FIELDS:
            x, y = getattr(a, field), getattr(b, field)
            assert x.dtype == y.dtype, f"step {k + 1}: {field}"
            assert x.tobytes() == y.tobytes(), f"step {k + 1}: {field}"
    # the run had both kinds of step: inputs that changed and inputs that held
    assert 0 < changed < 200


def test_the_reported_input_is_a_copy_of_what_the_simulation_writes():
    robot = load_robot("demo", control="kinematic")
    touched, clean = Simulation(robot), Simulation(robot)
    names, start = touched.joint_names, touched.joint_positions()
    target = {n: q + 0.2 for n, q in zip(names, start, strict=True)}
    for sim in (touched, clean):
        sim.set_positions(target)
        sim.step()
        sim.set_positions({n: q + 0.01 for n, q in target.items()})
        sim.step()
    applied = touched.last_input
    assert applied is not None
    assert np.any(applied.qvel_value != 0.0)
    applied.qpos_value[:] = 1.0
    applied.qvel_value[:] = 5.0
    for _ in range(3):
        touched.step()
        clean.step()
    assert touched.get_state().tobytes() == clean.get_state().tobytes()
    np.testing.assert_array_equal(touched.joint_commands(), clean.joint_commands())
