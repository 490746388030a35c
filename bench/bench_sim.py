"""Simulation.step against a raw mj_step loop on the same model, in the same run.

Rows: dynamic single steps (Python loop of ``sim.step()`` vs ``mj_step(m, d)``), dynamic batched
(``sim.step(n)`` vs ``mj_step(m, d, nstep=n)``): both must reach >= 0.9 of raw speed; and the
per-step cost with every arm joint kinematic, holding and with new positions each step
(``set_positions`` of the 7 arm joints, then ``step()``), against two limits: the bare
``mj_step`` loop (issue 20's row; it cannot hold a kinematic arm, so it is only a scale) and a
raw kinematic loop, the least a kinematic step can do in Python: numpy writes of the same
joints' qpos and finite-difference qvel before and after each ``mj_step``, nothing checked or
captured. The set_positions+step row must reach >= 0.7 of the raw kinematic loop.

Ours and raw are measured in short interleaved blocks and the best block of each is kept: the
machine is shared, and interleaving exposes both to the same interference.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import mujoco
import numpy as np
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


def _best_of_interleaved(fns: list[Callable[[], None]], rounds: int) -> list[float]:
    best = [math.inf] * len(fns)
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            start = time.perf_counter()
            fn()
            best[i] = min(best[i], time.perf_counter() - start)
    return best


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

    # The raw kinematic loop: the simulation's kinematic joints (the 7 arm joints first, the
    # fingers held), written as slices (the demo arm's addresses are consecutive).
    kdata = _raw_data(kin.model)
    ids = [mujoco.mj_name2id(kin.model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in sim.kinematic_joints]
    qadr = [int(kin.model.jnt_qposadr[j]) for j in ids]
    dadr = [int(kin.model.jnt_dofadr[j]) for j in ids]
    assert qadr == list(range(qadr[0], qadr[0] + len(ids))), "kinematic qpos not consecutive"
    assert dadr == list(range(dadr[0], dadr[0] + len(ids))), "kinematic qvel not consecutive"
    qs, ds = slice(qadr[0], qadr[0] + len(ids)), slice(dadr[0], dadr[0] + len(ids))
    arm = np.array(start)
    previous = [np.array(kdata.qpos[qs])]
    dt = kin.model.opt.timestep

    def raw_kinematic() -> None:
        qpos, qvel, q_prev = kdata.qpos, kdata.qvel, previous[0]
        for _ in range(block):
            counter[0] += 1
            offset = 0.1 * math.sin(counter[0] * 0.01)
            q = q_prev.copy()
            q[:7] = arm + offset
            v = (q - q_prev) / dt
            qpos[qs] = q
            qvel[ds] = v
            mujoco.mj_step(kin.model, kdata)
            qpos[qs] = q
            qvel[ds] = v
            q_prev = q
        previous[0] = q_prev

    t_moving, t_raw, t_raw_kin, t_holding = _best_of_interleaved(
        [moving, raw_kin, raw_kinematic, holding], rounds
    )
    rows.append(
        Row(
            "sim kinematic, set_positions+step vs raw mj_step",
            block / t_moving,
            block / t_raw,
            "st/s",
            "report",
            True,
            note=f"{t_moving / block * 1e6:.2f} us/step; raw kinematic loop "
            f"{t_raw / t_raw_kin:.2f} of it",
        )
    )
    ratio = t_raw_kin / t_moving
    rows.append(
        Row(
            "sim kinematic, set_positions+step vs raw kinematic loop",
            block / t_moving,
            block / t_raw_kin,
            "st/s",
            ">= 0.7",
            ratio >= 0.7,
            note=f"{t_raw_kin / block * 1e6:.2f} us/step raw",
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
