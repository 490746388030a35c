"""Observers, applied-input bookkeeping, reads and joint-behaviour metrics."""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from harness.models import load_robot
from harness.sim import Simulation
from harness.sim.metrics import (
    Trace,
    energy,
    energy_jumps,
    limit_violation,
    summarize,
    tracking_error,
    velocity_ratio,
)


def _sim(arm, mode="position") -> Simulation:
    return Simulation.from_model(arm.build(mode), control=dict.fromkeys(arm.joints, mode))


def test_observers_run_after_every_step_in_order_and_can_be_removed(arm):
    sim = _sim(arm)
    calls: list[tuple[str, int]] = []
    remove_a = sim.add_observer(lambda s: calls.append(("a", s.step_index)))
    sim.add_observer(lambda s: calls.append(("b", s.step_index)))
    sim.step(2)
    remove_a()
    sim.step()
    assert calls == [("a", 1), ("b", 1), ("a", 2), ("b", 2), ("b", 3)]
    assert sim.sim_time_ns == 3 * sim.dt_ns


def test_last_input_and_input_changed(arm):
    sim = _sim(arm)
    assert sim.last_input is None
    sim.step()
    first = sim.last_input
    assert first is not None
    assert sim.input_changed
    assert (first.step, first.sim_time_ns) == (1, sim.dt_ns)
    assert first.ctrl.dtype == np.float64
    assert first.ctrl.shape == (sim.model.nu,)
    assert first.qpos_index.size == 0
    assert first.qfrc_applied.size == 0
    sim.step()
    assert not sim.input_changed
    assert sim.last_input is not None
    assert sim.last_input.step == 2
    sim.command("j1", position=0.2)
    sim.step()
    assert sim.input_changed
    assert sim.last_input is not None
    assert sim.last_input.ctrl[0] == 0.2
    sim.command("j1", position=0.2)  # the same value again: no change reaches the physics
    sim.step()
    assert not sim.input_changed
    sim.apply_wrench("box", force=(0.0, 1.0, 0.0))
    sim.step()
    assert sim.input_changed
    assert sim.last_input is not None
    assert sim.last_input.xfrc_applied.shape == (sim.model.nbody * 6,)


def test_names_and_contacts(arm):
    sim = _sim(arm)
    sim.step()
    contacts = sim.contacts()
    pairs = {
        (sim.body_name(a), sim.body_name(b))
        for a, b in zip(contacts.body1, contacts.body2, strict=True)
    }
    assert ("table", "box") in pairs
    assert sim.geom_name(int(contacts.geom2[0])) in {"box_geom", "table_top"}
    assert sim.warning_counts()["BADQACC"] == 0


def test_metric_arrays():
    q = np.array([[0.0, 1.5], [-2.0, 0.5]])
    np.testing.assert_array_equal(
        limit_violation(q, np.array([-1.0, -1.0]), np.array([1.0, 1.0])),
        [[0.0, 0.5], [1.0, 0.0]],
    )
    np.testing.assert_array_equal(tracking_error(q, np.zeros_like(q)), np.abs(q))
    ratio = velocity_ratio(np.array([[2.0, 1.0]]), np.array([1.0, np.nan]))
    assert ratio[0, 0] == 2.0
    assert np.isnan(ratio[0, 1])
    np.testing.assert_array_equal(energy_jumps(np.array([1.0, 1.1, 3.0, 2.0]), 0.5), [2])


def test_energy_matches_mujoco_energy_flag_without_touching_the_model(arm):
    sim = _sim(arm)
    sim.set_positions(arm.targets(500))
    sim.step(200)
    qpos, qvel = sim.data.qpos.copy(), sim.data.qvel.copy()
    got = energy(sim.model, qpos, qvel)
    flagged = copy.copy(sim.model)
    flagged.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    d = mujoco.MjData(flagged)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(flagged, d)
    np.testing.assert_allclose(got[0], d.energy, rtol=1e-12)
    assert not sim.model.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_ENERGY)


def test_kinematic_jump_past_a_limit_shows_in_the_metrics():
    robot = load_robot("demo", control="kinematic")
    runs = {}
    for policy in ("clamp", "allow"):
        sim = Simulation(robot, kinematic_limits=policy)
        trace = Trace()
        trace.attach(sim)
        sim.step(5)
        sim.command("joint1", position=2.8973 + 0.3)  # 0.3 rad past the limit, in one step
        sim.step(20)
        runs[policy] = summarize(sim, trace.arrays())
    clamp, allow = runs["clamp"], runs["allow"]
    assert clamp.max_limit_violation[0] == 0.0
    assert abs(allow.max_limit_violation[0] - 0.3) < 1e-9
    assert allow.max_velocity_ratio[0] > clamp.max_velocity_ratio[0] > 1.0  # teleports spike
    assert clamp.max_tracking_error[0] == 0.0  # kinematic: exactly on command
    assert allow.warnings["BADQACC"] == 0


def test_position_mode_summary_on_the_demo():
    sim = Simulation(load_robot("demo", control="position"))
    trace = Trace()
    trace.attach(sim)
    sim.set_positions({"joint1": 0.5})
    sim.step(200)
    summary = summarize(sim, trace.arrays())
    assert 0.0 < summary.max_tracking_error[0] < 0.5
    assert summary.max_effort[0] <= 87.0 + 1e-9
    assert summary.peak_penetration >= 0.0
    assert np.isfinite(summary.max_energy_rise)
