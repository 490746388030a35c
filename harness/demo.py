"""``harness demo``: the demo arm pushes the box, in every control mode, twice, in two processes.

Each run loads the bundled demo robot (URDF) on its table scene, follows a scripted joint
trajectory for 5 s of simulation time that sweeps the hand through the box, and hashes the
``mjSTATE_INTEGRATION`` state after every step (SHA-256 of the whole state stream, initial
state included). The two processes must print identical hashes: that is the determinism claim.

Command laws per mode (``q_d``, ``dq_d``: the scripted trajectory): kinematic and position
command ``q_d``; velocity commands ``dq_d + K (q_d - q)``; effort commands
``Kp (q_d - q) + Kd (dq_d - dq) + bias`` with MuJoCo's gravity/Coriolis term of the last step.
"""

from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import math
import subprocess
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from harness.models.description import CONTROL_MODES, ControlMode

__all__ = [
    "ContactSummary",
    "ModeResult",
    "add_arguments",
    "run",
    "run_mode",
    "trajectory",
]

F64 = npt.NDArray[np.float64]

# Waypoints (joint1..joint7, finger) and the time each is reached, in seconds: home, beside
# the box, through it (the sweep pushes it along +y), back up with the gripper closing.
_ARM_HOME = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4, 0.04)
_BESIDE = (-0.027, -0.076, -0.26, -2.159, -0.022, 2.085, 0.449, 0.04)
_THROUGH = (0.027, -0.076, 0.26, -2.159, 0.022, 2.085, 1.122, 0.04)
_WAYPOINTS: tuple[tuple[float, tuple[float, ...]], ...] = (
    (0.0, _ARM_HOME),
    (1.2, _BESIDE),
    (3.4, _THROUGH),
    (5.0, (*_ARM_HOME[:7], 0.01)),
)
JOINTS = (*(f"joint{i}" for i in range(1, 8)), "finger_joint1")
"""The demo robot's controllable joints, in the order of the waypoints."""

_VELOCITY_GAIN = 20.0  # 1/s
_EFFORT_SATURATION = 0.05  # rad (m for the finger) of error that saturates the effort limit


def trajectory(t: float) -> tuple[F64, F64]:
    """Desired positions and velocities of :data:`JOINTS` at time ``t`` (s): cosine blends
    between waypoints, at rest at each waypoint."""
    for (t0, q0), (t1, q1) in itertools.pairwise(_WAYPOINTS):
        if t <= t1:
            u = min(max((t - t0) / (t1 - t0), 0.0), 1.0)
            a, b = np.array(q0), np.array(q1)
            s = (1 - math.cos(math.pi * u)) / 2
            ds = math.pi * math.sin(math.pi * u) / 2 / (t1 - t0)
            return a + (b - a) * s, (b - a) * ds
    return np.array(_WAYPOINTS[-1][1]), np.zeros(len(JOINTS))


class ContactSummary(NamedTuple):
    """Contacts between one robot link and one other body over a run."""

    robot_body: str
    other_body: str
    first_step: int
    steps: int
    peak_penetration: float
    peak_force: float


@dataclass
class _Pair:
    first_step: int
    last_step: int = -1
    steps: int = 0
    depth: float = 0.0
    force: float = 0.0


class ModeResult(NamedTuple):
    """One run of the demo in one control mode."""

    mode: ControlMode
    steps: int
    sha256: str
    contacts: tuple[ContactSummary, ...]
    box_travel: float


def run_mode(mode: ControlMode, seconds: float = 5.0) -> ModeResult:
    """Run the demo in ``mode`` and hash the state after every step."""
    from harness.models import load_robot
    from harness.sim import Simulation

    robot = load_robot("demo", control=mode)
    sim = Simulation(robot)
    steps = round(seconds * 1e9 / sim.dt_ns)
    model, data = sim.model, sim.data
    robot_bodies = {model.body(link.name).id for link in robot.description.links}
    dofs = np.array([model.jnt_dofadr[model.joint(j).id] for j in sim.joint_names])
    order = [JOINTS.index(j) for j in sim.joint_names]
    limits = np.array([robot.description.joint(j).limits.effort or 1.0 for j in sim.joint_names])
    kp = limits / _EFFORT_SATURATION
    kd = 2.0 * np.sqrt(kp * np.maximum(model.dof_M0[dofs], 1e-3))
    box = model.body("box").id
    box_start = data.xpos[box].copy()

    digest = hashlib.sha256(sim.get_state().tobytes())
    seen: dict[tuple[int, int], _Pair] = {}
    for k in range(steps):
        q_d, dq_d = trajectory(k * sim.dt_ns / 1e9)
        q_d, dq_d = q_d[order], dq_d[order]
        if mode in ("kinematic", "position"):
            sim.set_positions(dict(zip(sim.joint_names, q_d.tolist(), strict=True)))
        elif mode == "velocity":
            v = dq_d + _VELOCITY_GAIN * (q_d - sim.joint_positions())
            sim.set_velocities(dict(zip(sim.joint_names, v.tolist(), strict=True)))
        else:
            q, dq = sim.joint_positions(), sim.joint_velocities()
            tau = kp * (q_d - q) + kd * (dq_d - dq) + data.qfrc_bias[dofs]
            sim.set_efforts(dict(zip(sim.joint_names, tau.tolist(), strict=True)))
        sim.step()
        digest.update(sim.get_state().tobytes())
        contacts = sim.contacts()
        for i in range(contacts.size):
            b1, b2 = int(contacts.body1[i]), int(contacts.body2[i])
            if (b1 in robot_bodies) == (b2 in robot_bodies):
                continue
            pair = seen.setdefault((b1, b2) if b1 in robot_bodies else (b2, b1), _Pair(k + 1))
            if pair.last_step != k + 1:
                pair.last_step = k + 1
                pair.steps += 1
            pair.depth = max(pair.depth, float(contacts.depth[i]))
            pair.force = max(pair.force, float(contacts.normal_force[i]))
    summaries = tuple(
        ContactSummary(
            sim.body_name(b1), sim.body_name(b2), p.first_step, p.steps, p.depth, p.force
        )
        for (b1, b2), p in sorted(seen.items(), key=lambda kv: kv[1].first_step)
    )
    travel = float(np.linalg.norm(data.xpos[box] - box_start))
    return ModeResult(mode, steps, digest.hexdigest(), summaries, travel)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``harness demo``."""
    parser.add_argument(
        "--seconds", type=float, default=5.0, help="simulation time per run (default 5)"
    )
    parser.add_argument(
        "--mode", choices=CONTROL_MODES, action="append", help="only this mode (repeatable)"
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)


def _worker_command(args: argparse.Namespace, modes: tuple[ControlMode, ...]) -> list[str]:
    cmd = [sys.executable, "-m", "harness", "demo", "--worker", "--seconds", str(args.seconds)]
    for mode in modes:
        cmd += ["--mode", mode]
    return cmd


def _load(text: str) -> list[ModeResult]:
    out = []
    for item in json.loads(text):
        contacts = tuple(ContactSummary(*c) for c in item.pop("contacts"))
        out.append(ModeResult(**item, contacts=contacts))
    return out


def _as_json(results: list[ModeResult]) -> list[Mapping[str, object]]:
    return [{**r._asdict(), "contacts": [list(c) for c in r.contacts]} for r in results]


def run(args: argparse.Namespace) -> int:
    """Run the demo twice in two processes; exit 0 when both state streams hash the same."""
    modes: tuple[ControlMode, ...] = tuple(args.mode or CONTROL_MODES)
    if args.worker:
        print(json.dumps(_as_json([run_mode(m, args.seconds) for m in modes])))
        return 0
    procs = [
        subprocess.Popen(_worker_command(args, modes), stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    outputs = [p.communicate()[0] for p in procs]
    for i, p in enumerate(procs):
        if p.returncode != 0:
            print(f"harness demo: run {i + 1} failed (exit {p.returncode})", file=sys.stderr)
            return p.returncode
    first, second = (_load(o) for o in outputs)
    identical = all(a.sha256 == b.sha256 for a, b in zip(first, second, strict=True))
    if args.json:
        print(json.dumps({"identical": identical, "runs": [_as_json(first), _as_json(second)]}))
        return 0 if identical else 1
    _print_report(first, second, identical)
    return 0 if identical else 1


def _print_report(first: list[ModeResult], second: list[ModeResult], identical: bool) -> None:
    print("harness demo: the demo arm sweeps through the box; each mode run in 2 processes\n")
    for a, b in zip(first, second, strict=True):
        same = "identical" if a.sha256 == b.sha256 else "DIFFERENT"
        print(f"{a.mode:<9}  {a.steps} steps  box moved {a.box_travel * 1000:.1f} mm  {same}")
        print(f"  run 1 sha256 {a.sha256}")
        print(f"  run 2 sha256 {b.sha256}")
        for c in a.contacts:
            print(
                f"  contact {c.robot_body} - {c.other_body}: first step {c.first_step}, "
                f"{c.steps} steps, peak penetration {c.peak_penetration * 1000:.2f} mm, "
                f"peak normal force {c.peak_force:.2f} N"
            )
        if not a.contacts:
            print("  no robot contacts")
    verdict = "identical in every mode" if identical else "NOT identical"
    print(f"\nstate streams: {verdict}")
