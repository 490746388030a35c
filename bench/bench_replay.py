"""Replay-verify throughput against a raw ``mj_step`` loop of the same model, same run.

A recording of the demo arm (position servos, table scene, every step's state recorded, a new
command every 500 steps) is verified end to end with :func:`harness.replay.verify` (open,
version and model checks, decode of every state, re-simulation, bit-exact comparison); the
limit is a bare Python ``mj_step`` loop over the same number of steps. Target: >= 0.8. Also
reported: seconds to verify 60 s of 1 kHz simulation (60 000 steps; extrapolated when quick).
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

import mujoco
from common import Row

from harness.models import load_robot
from harness.recording import Recorder, describe_run
from harness.replay import verify
from harness.sim import Simulation


def _record(path: Path, steps: int) -> None:
    robot = load_robot("demo", control="position")
    sim = Simulation(robot)
    sim.reset()
    d = describe_run(robot)
    with Recorder(path, metadata=d.metadata, attachments=d.attachments) as rec:
        rec.write_physics_state(
            step=0, sim_time_ns=0, state_spec=sim.state_spec, state=sim.get_state(),
            qpos=sim.data.qpos, qvel=sim.data.qvel,
        )  # fmt: skip
        for k in range(steps):
            if k % 500 == 0:
                sign = 1.0 if (k // 500) % 2 else -1.0
                sim.set_positions({"joint1": 0.3 * sign, "joint2": 0.1 * sign})
            sim.step()
            if sim.input_changed:
                i = sim.last_input
                assert i is not None
                rec.write_applied_input(step=i.step, sim_time_ns=i.sim_time_ns, ctrl=i.ctrl)
            rec.write_physics_state(step=sim.step_index, sim_time_ns=sim.sim_time_ns,
                                    state_spec=sim.state_spec, state=sim.get_state(),
                                    qpos=sim.data.qpos, qvel=sim.data.qvel)  # fmt: skip


def run(quick: bool) -> list[Row]:
    steps = 5_000 if quick else 60_000
    rounds = 3 if quick else 5
    model = load_robot("demo", control="position").model
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        _record(path, steps)
        best_ours = best_raw = math.inf
        for _ in range(rounds):
            start = time.perf_counter()
            report = verify(path)
            best_ours = min(best_ours, time.perf_counter() - start)
            assert report.reproduced
            data = mujoco.MjData(model)
            mujoco.mj_resetDataKeyframe(model, data, 0)
            start = time.perf_counter()
            for _ in range(steps):
                mujoco.mj_step(model, data)
            best_raw = min(best_raw, time.perf_counter() - start)
    ours_rate, raw_rate = steps / best_ours, steps / best_raw
    return [
        Row(
            "replay verify throughput (demo arm, every state)",
            ours_rate,
            raw_rate,
            "st/s",
            ">= 0.8 of raw",
            ours_rate / raw_rate >= 0.8,
            note=f"{steps} steps, dt {model.opt.timestep:g} s",
        ),
        Row(
            "seconds to verify 60 s at 1 kHz (60k steps)",
            best_ours * 60_000 / steps,
            best_raw * 60_000 / steps,
            "s",
            "(reported)",
            True,
            higher_is_better=False,
            note="extrapolated" if steps != 60_000 else "measured",
        ),
    ]


if __name__ == "__main__":
    from common import format_table

    print(format_table(run(quick="--quick" in sys.argv)))
