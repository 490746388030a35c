"""Determinism: separate processes, mid-run restore (INTEGRATION yes, FULLPHYSICS no), replay
of the recorded applied inputs, batched vs single steps."""

from __future__ import annotations

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from harness.demo import JOINTS, trajectory
from harness.models import load_robot
from harness.sim import STATE_SPEC, AppliedInput, Simulation, StateError, advance, replay

CHILD = """
import json
from harness.demo import run_mode
r = run_mode("position", seconds=20.0)
print(json.dumps([r.steps, r.sha256, len(r.contacts)]))
"""


@pytest.mark.slow
def test_two_processes_hash_the_same_10000_steps_with_contacts():
    procs = [
        subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    outs = [p.communicate(timeout=120)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0]
    first, second = outs
    steps, digest, contacts = json.loads(first)
    assert steps == 10_000
    assert contacts >= 1  # the arm touched the box
    assert len(digest) == 64
    assert first == second


def _demo_sim(mode: str = "position") -> Simulation:
    return Simulation(load_robot("demo", control=mode))


def _command(sim: Simulation, step: int) -> None:
    q_d, _ = trajectory(step * sim.dt_ns / 1e9)
    order = [JOINTS.index(j) for j in sim.joint_names]
    sim.set_positions(dict(zip(sim.joint_names, q_d[order].tolist(), strict=True)))


def test_integration_state_restores_bit_exactly_and_fullphysics_does_not():
    sim = _demo_sim()
    restore_at, end = 1000, 1300  # the fingers touch the box from about step 940
    inputs: list[AppliedInput] = []
    states: dict[int, np.ndarray] = {}
    for k in range(end):
        _command(sim, k)
        sim.step()
        assert sim.last_input is not None
        inputs.append(sim.last_input)
        states[sim.step_index] = sim.get_state()
    assert sim.contacts().size > 0

    model = sim.model
    full = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    scratch = mujoco.MjData(model)
    mujoco.mj_setState(model, scratch, states[restore_at], STATE_SPEC)
    mujoco.mj_getState(model, scratch, full, mujoco.mjtState.mjSTATE_FULLPHYSICS)

    exact = mujoco.MjData(model)
    mujoco.mj_setState(model, exact, states[restore_at], STATE_SPEC)
    partial = mujoco.MjData(model)
    mujoco.mj_setState(model, partial, full, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    diverged = 0.0
    for inp in inputs[restore_at:]:
        advance(model, exact, inp)
        advance(model, partial, inp)
        got = np.empty_like(states[inp.step])
        mujoco.mj_getState(model, exact, got, STATE_SPEC)
        np.testing.assert_array_equal(got, states[inp.step])
        diverged = max(diverged, float(np.abs(partial.qpos - exact.qpos).max()))
    # Without the solver warmstart the run differs (qacc_warmstart is not in FULLPHYSICS).
    assert diverged > 0.0


def test_simulation_set_state_continues_bit_exactly():
    sim = _demo_sim()
    for k in range(1000):
        _command(sim, k)
        sim.step()
    mid = sim.get_state()
    expected = []
    for k in range(1000, 1200):
        _command(sim, k)
        sim.step()
        expected.append(sim.get_state())
    fresh = _demo_sim()
    fresh.set_state(mid, 1000)
    assert fresh.sim_time_ns == 1000 * fresh.dt_ns
    np.testing.assert_array_equal(fresh.get_state(), mid)  # set_state's mj_forward wrote no state
    for k in range(1000, 1200):
        _command(fresh, k)
        fresh.step()
        np.testing.assert_array_equal(fresh.get_state(), expected[k - 1000])


@pytest.mark.parametrize("mode", ["kinematic", "position", "effort"])
def test_recorded_inputs_replay_the_run_bit_for_bit(mode, arm):
    model = arm.build(mode)
    sim = Simulation.from_model(model, control=dict.fromkeys(arm.joints, mode))
    initial = sim.get_state()
    recorded: list[AppliedInput] = []
    states = []
    for k in range(1100):
        targets = arm.targets(k)
        if mode == "effort":
            error = np.array([targets[j] for j in arm.joints]) - sim.joint_positions()
            sim.set_efforts(dict(zip(arm.joints, (60 * error).tolist(), strict=True)))
        else:
            sim.set_positions(targets)
        sim.step()
        if sim.input_changed:
            assert sim.last_input is not None
            recorded.append(sim.last_input)
        states.append(sim.get_state())
    if mode == "kinematic":
        assert recorded[-1].kinematic_joints == (*arm.joints, "finger_right_joint")
    if mode != "effort":  # the sweep ends at step 1000: the held input is not repeated
        assert recorded[-1].step <= 1002 < len(states)  # kinematic: +1 for velocity -> 0
    replayed = list(replay(model, initial, recorded, end_step=1100))
    assert [s for s, _ in replayed] == list(range(1, 1101))
    for (_, got), want in zip(replayed, states, strict=True):
        np.testing.assert_array_equal(got, want)


def test_batched_steps_equal_single_steps(arm):
    model = arm.build("position")
    control = dict.fromkeys(arm.joints, "position")
    batched = Simulation.from_model(model, control=control)
    single = Simulation.from_model(model, control=control)
    for sim in (batched, single):
        sim.set_positions(arm.targets(300))
    batched.step(500)
    for _ in range(500):
        single.step()
    assert batched.step_index == single.step_index == 500
    np.testing.assert_array_equal(batched.get_state(), single.get_state())


def test_reset_reproduces_the_run():
    sim = _demo_sim("velocity")
    first = []
    for _ in range(2):
        sim.reset()
        assert sim.step_index == 0
        for k in range(300):
            sim.set_velocities({"joint1": 0.5 * np.sin(k / 50), "joint4": 0.3})
            sim.step()
        first.append(sim.get_state())
    np.testing.assert_array_equal(first[0], first[1])


def test_get_state_into_a_buffer_equals_a_new_array() -> None:
    """``get_state(out=)`` fills the caller's buffer with the same bits, and refuses a buffer
    of the wrong size or type with one line naming it."""
    sim = Simulation(load_robot("demo"))
    buffer = np.full(sim.state_size, np.nan)
    for _ in range(20):
        sim.step()
        assert sim.get_state(buffer) is buffer
        assert buffer.tobytes() == sim.get_state().tobytes()
    for bad in (np.zeros(3), np.zeros(sim.state_size, np.float32)):
        with pytest.raises(StateError, match=r"get_state\(out=\): out must be a writable"):
            sim.get_state(bad)
