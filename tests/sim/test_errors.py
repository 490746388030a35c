"""Refused set-ups and unstable runs: one clear error naming what and where."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.errors import SimulationError
from harness.sim import (
    ControlConfigError,
    InstabilityError,
    Simulation,
    StateError,
    TimestepError,
)


def _unstable(arm) -> Simulation:
    model = arm.build("position", kp=1e6, force_limits=False)
    sim = Simulation.from_model(model, control=dict.fromkeys(arm.joints, "position"))
    sim.set_positions({"j2": 1.2, "j3": -1.0})
    return sim


def _step_singly(sim: Simulation, n: int) -> None:
    for _ in range(n):
        sim.step()


def test_unstable_servo_raises_naming_step_and_badqacc(arm):
    sim = _unstable(arm)
    with pytest.raises(InstabilityError) as info:
        _step_singly(sim, 2000)
    err = info.value
    assert err.warning == "BADQACC"
    assert err.step == sim.step_index
    assert str(err).startswith(f"step {err.step} (sim time {err.step * 2_000_000} ns)")
    assert "MuJoCo warning BADQACC" in str(err)
    with pytest.raises(SimulationError, match=f"failed at step {err.step}"):
        sim.step()
    sim.reset()  # a reset makes it usable again
    sim.step()
    assert sim.step_index == 1


def test_batched_run_names_the_same_failing_step(arm):
    single = _unstable(arm)
    with pytest.raises(InstabilityError) as first:
        _step_singly(single, 2000)
    batched = _unstable(arm)
    with pytest.raises(InstabilityError) as second:
        batched.step(2000)
    assert second.value.step == first.value.step
    assert second.value.warning == "BADQACC"


def test_huge_force_on_a_light_body_is_caught(arm):
    sim = Simulation.from_model(arm.build("position"), control={"j1": "position"})
    sim.apply_wrench("box", force=(0.0, 0.0, 1e300))
    with pytest.raises(InstabilityError, match=r"^step 1 \(sim time 2000000 ns\): MuJoCo warning"):
        sim.step()


def test_timestep_not_whole_nanoseconds_is_refused(arm):
    model = arm.build("position", timestep=1 / 3000)
    with pytest.raises(TimestepError, match=r"timestep 0\.000333\d* s is not a whole number"):
        Simulation.from_model(model, control={"j1": "position"})
    ok = Simulation.from_model(arm.build("position", timestep=0.001), control={"j1": "position"})
    assert ok.dt_ns == 1_000_000


@pytest.mark.parametrize(
    ("control", "build", "message"),
    [
        ({"elbow": "position"}, "position", "control names joint 'elbow', which the model lacks"),
        ({"box_joint": "position"}, "position", "'box_joint' is not a hinge or slide joint"),
        ({"j1": "kinematic"}, "position", "'j1' is kinematic but actuator 'j1' drives it"),
        ({"j1": "position"}, "kinematic", "'j1' \\(position\\) needs exactly one joint actuator"),
        ({"j1": "velocity"}, "position", "its actuator 'j1' is a position actuator"),
        ({"finger_right_joint": "kinematic"}, "kinematic", "mimics 'finger_left_joint'"),
        ({"j1": "torque"}, "position", "control mode 'torque' is not one of"),
    ],
)
def test_control_mapping_errors(arm, control, build, message):
    with pytest.raises(ControlConfigError, match=message):
        Simulation.from_model(arm.build(build), control=control)


def test_sleeping_is_refused(arm):
    with pytest.raises(ControlConfigError, match="enables sleeping"):
        Simulation.from_model(arm.build("position", sleep=True), control={"j1": "position"})


def test_bad_states_are_refused(arm):
    sim = Simulation.from_model(arm.build("position"), control={"j1": "position"})
    sim.step(10)
    state = sim.get_state()
    with pytest.raises(StateError, match=r"state has shape \(3,\)"):
        sim.set_state(np.zeros(3), 0)
    with pytest.raises(StateError, match="does not match step 11"):
        sim.set_state(state, 11)
    bad = state.copy()
    bad[5] = np.nan
    with pytest.raises(StateError, match="non-finite"):
        sim.set_state(bad, 10)
    sim.set_state(state, 10)
    assert sim.step_index == 10
    assert int(mujoco.mjtState.mjSTATE_INTEGRATION) == sim.state_spec


def test_bare_steps_told_with_stepped_are_steps_and_are_checked(arm):
    """A caller's own ``mj_step`` calls while ``plain`` holds, then ``stepped(n)``: the same
    state and count as ``step``; a failure among them is raised then (naming the last)."""
    ours = Simulation.from_model(arm.build("position"), control={"j1": "position"})
    theirs = Simulation.from_model(arm.build("position"), control={"j1": "position"})
    for sim in (ours, theirs):
        sim.set_positions({"j1": 0.3})
        sim.step()  # the command's step: not a bare one
    assert ours.plain
    for _ in range(50):
        mujoco.mj_step(ours.model, ours.data)
    ours.stepped(50)
    theirs.step(50)
    assert ours.step_index == theirs.step_index == 51
    assert np.array_equal(ours.get_state(), theirs.get_state())
    ours.set_positions({"j1": 0.0})
    assert not ours.plain  # a command is pending: step() prepares it

    sim = _unstable(arm)
    sim.step()
    assert sim.plain
    for _ in range(2000):
        mujoco.mj_step(sim.model, sim.data)
    with pytest.raises(InstabilityError) as info:
        sim.stepped(2000)
    assert info.value.step == 2001
