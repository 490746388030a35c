"""``harness demo``: the showcase. The demo scenario run over the real bridge, recorded, judged,
replay-verified and re-simulated in the other control mode; then the physics alone proven
deterministic across processes in every control mode.

1. ``scenarios/demo.yaml``: the bundled arm on its table scene, driven in lockstep over rosbridge
   by the scripted roslibpy client ``scenarios/clients/demo_arm.py`` (run by this interpreter),
   which follows :func:`trajectory` (the hand sweeps through the box). Two iterations in two
   worker processes through the session-backed runner (``harness run`` machinery): each
   recorded to MCAP, judged (collisions except with the box, joint limits) and hashed (SHA-256
   of every step's ``mjSTATE_INTEGRATION`` state); the two hashes must be equal. Reports
   (``report.html``, ``junit.xml``, ``results.json``) go to ``--out``.
2. The first recording replayed from its inputs (:func:`harness.replay.verify`): bit for bit.
3. The same recording re-simulated with every joint in the other control mode
   (:func:`harness.replay.resimulate`: position -> kinematic), its findings summarised: what a
   switch of control mode would show (velocity spikes of kinematic "jumping", penetration).
4. Without the bridge: each control mode run for ``--seconds`` in two processes
   (:func:`run_mode`), the state streams hashed; the two processes must print identical hashes.

Command laws per mode in step 4 (``q_d``, ``dq_d``: the scripted trajectory): kinematic and
position command ``q_d``; velocity commands ``dq_d + K (q_d - q)``; effort commands
``Kp (q_d - q) + Kd (dq_d - dq) + bias`` with MuJoCo's gravity/Coriolis term of the last step.

Exit code 0 when the scenario passed, its iterations hashed the same, the replay reproduced the
recording and every mode hashed the same in both processes.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import itertools
import json
import math
import subprocess
import sys
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from harness.errors import ConfigError, SimulationError
from harness.models.description import CONTROL_MODE_INPUTS, CONTROL_MODES, ControlMode
from harness.vocabulary import Actuation

if TYPE_CHECKING:
    from harness.replay import Finding, ResimReport

__all__ = [
    "MOBILE_SCENARIO",
    "SCENARIO",
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


SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "demo.yaml"
"""The demo scenario of a source checkout."""
MOBILE_SCENARIO = SCENARIO.with_name("mobile-glance.yaml")
"""The mobile robot's sensor glance run beside the demo scenario (its lidar scan and camera
frame go into the same report.html)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``harness demo``."""
    parser.add_argument(
        "--seconds",
        type=float,
        default=5.0,
        help="simulation time per run of the per-mode proof (default 5)",
    )
    parser.add_argument(
        "--mode",
        choices=CONTROL_MODE_INPUTS,
        action="append",
        help="only this mode in the per-mode proof (repeatable)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("harness-results") / "demo",
        metavar="DIR",
        help="where the recordings and report.html go (default harness-results/demo)",
    )
    parser.add_argument(
        "--scenario",
        type=Path,
        default=SCENARIO,
        metavar="FILE",
        help="the scenario to showcase (default: scenarios/demo.yaml)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print only the per-mode proof's results as JSON"
    )
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


class _Proof:
    """The per-mode proof running in two worker processes."""

    def __init__(self, args: argparse.Namespace, modes: tuple[ControlMode, ...]) -> None:
        self.procs = [
            subprocess.Popen(_worker_command(args, modes), stdout=subprocess.PIPE, text=True)
            for _ in range(2)
        ]

    def results(self) -> tuple[list[ModeResult], list[ModeResult]]:
        outputs = [p.communicate()[0] for p in self.procs]
        for i, p in enumerate(self.procs):
            if p.returncode != 0:
                raise SimulationError(f"per-mode proof: run {i + 1} failed (exit {p.returncode})")
        first, second = (_load(o) for o in outputs)
        return first, second

    def stop(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()


def run(args: argparse.Namespace) -> int:
    """The showcase (see the module docstring); exit 0 when every check held."""
    modes = tuple(dict.fromkeys(ControlMode.parse(m) for m in args.mode or CONTROL_MODES))
    if args.worker:
        print(json.dumps(_as_json([run_mode(m, args.seconds) for m in modes])))
        return 0
    proof = _Proof(args, modes)
    try:
        if args.json:
            first, second = proof.results()
            identical = _identical(first, second)
            print(json.dumps({"identical": identical, "runs": [_as_json(first), _as_json(second)]}))
            return 0 if identical else 1
        showcase = _showcase(args.scenario, args.out)
        first, second = proof.results()
    finally:
        proof.stop()
    print(
        "\n4. Physics alone, every control mode, each run in 2 processes "
        f"({args.seconds:g} s of simulation)"
    )
    _print_report(first, second)
    identical = _identical(first, second)
    checks = [*showcase.checks, ("per-mode state streams identical", identical)]
    failed = [name for name, ok in checks if not ok]
    print(f"\nreport: {showcase.report}")
    if failed:
        print(f"verdict: FAIL ({'; '.join(failed)})")
        return 1
    print("verdict: PASS (" + "; ".join(name for name, _ in checks) + ")")
    return 0


def _identical(first: list[ModeResult], second: list[ModeResult]) -> bool:
    return all(a.sha256 == b.sha256 for a, b in zip(first, second, strict=True))


class _Showcase(NamedTuple):
    report: Path
    checks: list[tuple[str, bool]]


def _showcase(scenario_path: Path, out: Path) -> _Showcase:
    """Steps 1-3: the scenario over the bridge, replay verification, re-simulation."""
    from rich.console import Console

    from harness.replay import resimulate, verify
    from harness.scenario import (
        LocalBackend,
        load_run_file,
        run_scenarios,
        session_iteration_runner,
    )

    if not scenario_path.is_file():
        raise ConfigError(
            f"{scenario_path}: the demo scenario is not there (it ships in a source checkout's "
            "scenarios/ folder; pass --scenario FILE)"
        )
    config = load_run_file(scenario_path)
    scenario = config.simulations[0].scenario
    if MOBILE_SCENARIO.is_file():
        glance = load_run_file(MOBILE_SCENARIO).simulations
        config = dataclasses.replace(config, simulations=(*config.simulations, *glance))
    robot = scenario.robots[0]
    recorded_modes = {c.mode for c in robot.modes} or {ControlMode.POSITION}
    other = Actuation.SERVO if recorded_modes == {"kinematic"} else Actuation.KINEMATIC
    print(
        f"harness demo: {scenario.name}: {scenario.description}\n"
        f"1. The scenario over the rosbridge bridge, 2 iterations in 2 worker processes, recorded"
        " (with the mobile robot's sensor glance: a lidar scan and a camera frame in the report)"
    )
    console = Console(highlight=False)
    results = run_scenarios(
        config,
        session_iteration_runner(),
        LocalBackend(2),
        out,
        console,
        iterations=2,
        check_determinism=True,
    )
    checks: list[tuple[str, bool]] = [
        ("scenario passed", all(r.passed for r in results)),
    ]
    results = [r for r in results if r.simulation == config.simulations[0].name]
    for r in results:
        print(f"  iteration {r.iteration} state sha256 {r.state_digest}")
    same = len({r.state_digest for r in results}) == 1 and results[0].state_digest is not None
    print(f"  iterations: {'identical' if same else 'DIFFERENT'} state streams")
    checks.append(("iterations identical", same))
    recording = results[0].recording
    if recording is None or not recording.is_file():
        print("2. Replay: no recording to verify")
        checks.append(("replay reproduced", False))
        return _Showcase(out.resolve() / "report.html", checks)
    print(f"2. Replay of {recording} from its inputs (harness.replay.verify)")
    verified = verify(recording)
    print("  " + verified.format().replace("\n", "\n  "))
    checks.append(("replay reproduced", verified.reproduced))
    print(f"3. Re-simulation with {other} actuation (harness.replay.resimulate)")
    resim = resimulate(recording, other)
    for line in _resim_summary(resim):
        print(f"  {line}")
    return _Showcase(out.resolve() / "report.html", checks)


def _resim_summary(report: ResimReport) -> list[str]:
    """A few lines: the findings counted per run and quantity, the first of each, contacts."""
    lines = [
        f"{report.steps} steps: recorded ({report.recorded.control}) vs re-simulated "
        f"({report.resimulated.control})"
    ]
    if not report.findings:
        lines.append("no finding: the switch of control mode changes nothing measurable")
    counts = Counter((f.run, f.quantity) for f in report.findings)
    firsts: dict[tuple[str, str], Finding] = {}
    for f in report.findings:
        firsts.setdefault((f.run, f.quantity), f)
    for (run, quantity), f in sorted(firsts.items(), key=lambda kv: kv[1].step):
        what = f"{quantity} {f.name}".strip()
        lines.append(
            f"{run}: {quantity} exceeded {counts[(run, quantity)]}x, first {what} = "
            f"{f.value:.4g} > {f.threshold:g} at step {f.step}"
        )
    re, rec = report.resimulated, report.recorded
    lines.append(
        f"peak penetration {rec.peak_penetration * 1000:.2f} mm recorded vs "
        f"{re.peak_penetration * 1000:.2f} mm re-simulated; max energy jump "
        f"{rec.max_energy_jump:.3g} J vs {re.max_energy_jump:.3g} J"
    )
    if report.contacts_appearing:
        lines.append(f"contacts only when re-simulated: {', '.join(report.contacts_appearing)}")
    if report.contacts_disappearing:
        lines.append(f"contacts only when recorded: {', '.join(report.contacts_disappearing)}")
    return lines


def _print_report(first: list[ModeResult], second: list[ModeResult]) -> None:
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
    verdict = "identical in every mode" if _identical(first, second) else "NOT identical"
    print(f"state streams: {verdict}")
