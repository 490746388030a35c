"""Replay-verify throughput against a raw ``mj_step`` loop of the same model, same run.

A recording of the demo arm (position servos, table scene, every step's state recorded, a new
command every 500 steps) is verified end to end with :func:`harness.replay.verify` (open,
every CRC checked, version and model checks, decode of every state, re-simulation, bit-exact
comparison of every state). CRCs use ISA-L when the optional ``isal`` package is installed
(``harness.recording._crc``), zlib otherwise.

The limit is a bare Python ``mj_step`` loop over the *same trajectory*: the same model from the
same initial state, with ``ctrl`` written at the steps where the recording changed it, and
nothing else (no reading, no state capture, no comparison). Its final state is checked to equal
the recording's, so it does exactly the physics verify must redo. Target: >= 0.8.

Also reported: seconds to verify 60 s of 1 kHz simulation (60 000 steps; extrapolated when
quick), and, for comparison with earlier figures, a raw loop of the arm resting at its keyframe
(no commands): fewer contacts and solver iterations make it ~30 % cheaper per step than the
recorded trajectory, so it is not the limit of this workload.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt
from common import Row

from harness.models import load_robot
from harness.recording import AppliedInput, PhysicsState, Recorder, Recording, describe_run
from harness.replay import verify
from harness.sim import Simulation

F64 = npt.NDArray[np.float64]


def _record(path: Path, steps: int) -> None:
    robot = load_robot("demo", control="position")
    sim = Simulation(robot)
    sim.reset()
    d = describe_run(robot)
    with Recorder(path, metadata=d.metadata, attachments=d.attachments) as rec:
        rec.write_physics_state(PhysicsState(
            step=0, sim_time_ns=0, state_spec=sim.state_spec, state=sim.get_state(),
            qpos=sim.data.qpos, qvel=sim.data.qvel,
        ))  # fmt: skip
        for k in range(steps):
            if k % 500 == 0:
                sign = 1.0 if (k // 500) % 2 else -1.0
                sim.set_positions({"joint1": 0.3 * sign, "joint2": 0.1 * sign})
            sim.step()
            if sim.input_changed:
                i = sim.last_input
                assert i is not None
                rec.write_applied_input(
                    AppliedInput(step=i.step, sim_time_ns=i.sim_time_ns, ctrl=i.ctrl)
                )
            rec.write_physics_state(PhysicsState(step=sim.step_index, sim_time_ns=sim.sim_time_ns,
                                    state_spec=sim.state_spec, state=sim.get_state(),
                                    qpos=sim.data.qpos, qvel=sim.data.qvel))  # fmt: skip


def _trajectory(path: Path) -> tuple[F64, int, list[tuple[int, F64]], F64]:
    """What the raw loop needs (read once, untimed): the initial state and its spec, the
    ``(step, ctrl)`` changes, and the recorded final qpos."""
    with Recording(path) as rec:
        (first,) = rec.physics_states(0, 1)
        (last,) = rec.physics_states(rec.last_step, rec.last_step + 1)
        changes = [(i.step, np.asarray(i.ctrl, dtype=np.float64)) for i in rec.applied_inputs()]
    return np.asarray(first.state), first.state_spec, changes, np.asarray(last.qpos)


def _raw_loop(
    model: mujoco.MjModel,
    initial: F64,
    spec: int,
    changes: list[tuple[int, F64]],
    steps: int,
) -> tuple[float, F64]:
    """Seconds for ``steps`` bare ``mj_step`` calls along the recorded trajectory (the input
    with step ``s`` is written before step ``s``); the final qpos."""
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, initial, spec)
    step = mujoco.mj_step
    start = time.perf_counter()
    done = 0
    for at, ctrl in [*changes, (steps + 1, None)]:
        for _ in range(min(at, steps + 1) - 1 - done):
            step(model, data)
        done = min(at, steps + 1) - 1
        if ctrl is not None:
            data.ctrl[:] = ctrl
    return time.perf_counter() - start, data.qpos.copy()


def _rest_loop(model: mujoco.MjModel, steps: int) -> float:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return time.perf_counter() - start


def run(quick: bool) -> list[Row]:
    steps = 5_000 if quick else 60_000
    rounds = 3 if quick else 7
    model = load_robot("demo", control="position").model
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        _record(path, steps)
        initial, spec, changes, final_qpos = _trajectory(path)
        best_ours = best_raw = best_rest = math.inf
        for _ in range(rounds):  # interleaved: the machine is shared and noisy
            start = time.perf_counter()
            report = verify(path)
            best_ours = min(best_ours, time.perf_counter() - start)
            assert report.reproduced
            assert report.states_compared == steps
            seconds, qpos = _raw_loop(model, initial, spec, changes, steps)
            assert np.array_equal(qpos, final_qpos), "the raw loop left the recorded trajectory"
            best_raw = min(best_raw, seconds)
            best_rest = min(best_rest, _rest_loop(model, steps))
    ours_rate, raw_rate = steps / best_ours, steps / best_raw
    scale = 60_000 / steps
    return [
        Row(
            "replay verify throughput (demo arm, every state)",
            ours_rate,
            raw_rate,
            "st/s",
            ">= 0.8 of raw (same trajectory)",
            ours_rate / raw_rate >= 0.8,
            note=f"{steps} steps, dt {model.opt.timestep:g} s, {len(changes)} input changes",
        ),
        Row(
            "seconds to verify 60 s at 1 kHz (60k steps)",
            best_ours * scale,
            best_raw * scale,
            "s",
            "(reported)",
            True,
            higher_is_better=False,
            note="extrapolated" if steps != 60_000 else "measured",
        ),
        Row(
            "raw loop: recorded trajectory vs arm at rest",
            raw_rate,
            steps / best_rest,
            "st/s",
            "(reported: the old limit)",
            True,
            note="the resting arm is cheaper per step; verify is judged against the first",
        ),
    ]


if __name__ == "__main__":
    from common import format_table

    print(format_table(run(quick="--quick" in sys.argv)))
