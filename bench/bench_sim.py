"""Simulation.step against a raw mj_step loop on the same model, in the same run.

Rows: dynamic single steps (Python loop of ``sim.step()`` vs ``mj_step(m, d)``), dynamic batched
(``sim.step(n)`` vs ``mj_step(m, d, nstep=n)``): both must reach >= 0.9 of raw speed; and the
per-step cost with every arm joint kinematic, holding and with a new command each step (reported;
the raw loop cannot hold a kinematic arm, so its figure there is only a scale).

Ours and raw are measured in short interleaved blocks and the best block of each is kept: the
machine is shared, and interleaving exposes both to the same interference.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import mujoco
from common import Row

from harness.models import load_robot
from harness.sim import Simulation


def _interleaved(
    ours: Callable[[], None], raw: Callable[[], None], rounds: int
) -> tuple[float, float]:
    best_ours = best_raw = math.inf
    for _ in range(rounds):
        start = time.perf_counter()
        ours()
        best_ours = min(best_ours, time.perf_counter() - start)
        start = time.perf_counter()
        raw()
        best_raw = min(best_raw, time.perf_counter() - start)
    return best_ours, best_raw


def _raw_data(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    return data


def run(quick: bool) -> list[Row]:
    block, rounds = (500, 10) if quick else (2_000, 25)
    rows: list[Row] = []
    robot = load_robot("demo", control="position")
    model = robot.model

    sim = Simulation(robot)
    data = _raw_data(model)

    def ours_single() -> None:
        for _ in range(block):
            sim.step()

    def raw_single() -> None:
        for _ in range(block):
            mujoco.mj_step(model, data)

    t_ours, t_raw = _interleaved(ours_single, raw_single, rounds)
    ratio = t_raw / t_ours
    rows.append(
        Row(
            "sim dynamic step() loop vs raw mj_step loop",
            block / t_ours,
            block / t_raw,
            "st/s",
            ">= 0.9",
            ratio >= 0.9,
            note=f"{t_ours / block * 1e6:.2f} us/step",
        )
    )

    sim = Simulation(robot)
    data = _raw_data(model)
    t_ours, t_raw = _interleaved(
        lambda: sim.step(block), lambda: mujoco.mj_step(model, data, nstep=block), rounds
    )
    ratio = t_raw / t_ours
    rows.append(
        Row(
            "sim dynamic step(n) vs raw mj_step(nstep=n)",
            block / t_ours,
            block / t_raw,
            "st/s",
            ">= 0.9",
            ratio >= 0.9,
            note=f"{t_ours / block * 1e6:.2f} us/step",
        )
    )

    kin = load_robot("demo", control="kinematic")
    sim = Simulation(kin)
    names = sim.joint_names[:7]
    start = sim.joint_positions()[:7].tolist()
    data = _raw_data(kin.model)
    counter = [0]

    def moving() -> None:
        for _ in range(block):
            counter[0] += 1
            offset = 0.1 * math.sin(counter[0] * 0.01)
            sim.set_positions({n: q + offset for n, q in zip(names, start, strict=True)})
            sim.step()

    def holding() -> None:
        for _ in range(block):
            sim.step()

    def raw_kin() -> None:
        for _ in range(block):
            mujoco.mj_step(kin.model, data)

    t_moving, t_raw = _interleaved(moving, raw_kin, rounds)
    t_holding, _ = _interleaved(holding, lambda: None, rounds)
    rows.append(
        Row(
            "sim kinematic, set_positions+step vs raw",
            block / t_moving,
            block / t_raw,
            "st/s",
            "report",
            True,
            note=f"{t_moving / block * 1e6:.2f} us/step",
        )
    )
    rows.append(
        Row(
            "sim kinematic, holding vs raw",
            block / t_holding,
            block / t_raw,
            "st/s",
            "report",
            True,
            note=f"{t_holding / block * 1e6:.2f} us/step",
        )
    )
    return rows
