"""Logger overhead per step with 0, 10 and 100 active contacts, against the bare step; the
per-step cost of a scenario run against the bare step.

The scene: N spheres resting on a plane (one contact each; N = 0 keeps one sphere in the air),
settled first. Measured in the same run: a raw ``mj_step`` loop of the same model (the limit),
and ``mj_step`` + ``extract_contacts`` + ``EventHub.observe`` with a CollisionLogger (every
step), a JointLimitLogger (every step) and a JointLogger at 100 Hz into a collecting sink.

The scenario run: ``tests/explore/data/sweep.yaml`` (the demo arm's scripted sweep past a post,
1.5 s at 2 ms: 750 steps) as ``harness explore`` runs an example: the product's iteration
runner with whole spans per step request, its loggers (collisions, joint limits, the
runner's observer) and a clearance logger, recording off and on. Per step: the time between
two consecutive steps' observations on the session's thread (everything a step costs: the
controllers, ``mj_step``, the loggers, recording, publishing, the session loop), as the
thread's CPU time (steady on a loaded machine), best of the runs, against a raw ``mj_step``
loop of the same compiled model in the same run (CPU time too).
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco
import yaml
from common import Row, best_of

from harness.events import (
    ClearanceLogger,
    CollectingSink,
    CollisionLogger,
    EventHub,
    JointLimitLogger,
    JointLogger,
    StepContext,
)
from harness.scenario import iteration_specs, load_run_file, session_iteration_runner
from harness.sim.contacts import extract_contacts


def scene(n: int) -> mujoco.MjModel:
    bodies = []
    for i in range(max(n, 1)):
        x, y = (i % 10) * 0.3, (i // 10) * 0.3
        z = 0.1 if n else 1.0
        bodies.append(
            f'<body name="ball{i}" pos="{x} {y} {z}"><freejoint/>'
            f'<geom type="sphere" size="0.1" mass="1"/></body>'
        )
    gravity = "0 0 -9.81" if n else "0 0 0"
    xml = (
        f'<mujoco><option timestep="0.002" gravity="{gravity}"/><worldbody>'
        f'<geom name="floor" type="plane" size="10 10 0.1"/>{"".join(bodies)}'
        "</worldbody></mujoco>"
    )
    return mujoco.MjModel.from_xml_string(xml)


def measure(n: int, steps: int, repeats: int) -> tuple[float, float, int]:
    model = scene(n)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 500)  # settle
    ncon = int(data.ncon)
    start = mujoco.MjData(model)
    mujoco.mj_copyData(start, model, data)

    def bare() -> None:
        mujoco.mj_copyData(data, model, start)
        for _ in range(steps):
            mujoco.mj_step(model, data)

    def logged() -> None:
        mujoco.mj_copyData(data, model, start)
        hub = EventHub(
            [
                CollisionLogger(model, debounce_steps=5),
                JointLimitLogger(model),
                JointLogger(model, rate_hz=100),
            ],
            [CollectingSink()],
        )
        dt_ns = 2_000_000
        for k in range(1, steps + 1):
            mujoco.mj_step(model, data)
            hub.observe(StepContext(k, k * dt_ns, model, data, extract_contacts(model, data), "b"))

    t_bare = best_of(bare, repeats) / steps
    t_logged = best_of(logged, repeats) / steps
    return t_bare * 1e6, t_logged * 1e6, ncon


SWEEP = Path(__file__).resolve().parents[1] / "tests" / "explore" / "data" / "sweep.yaml"
STEP_TARGET_US = 20.0
"""Issue 36: a scenario run's Python per step (over ``mj_step``) when nothing changes."""


class _Clock:
    """A logger noting the session thread's CPU time at every observed step (emits nothing)."""

    name = "bench-clock"
    period_ns = 0

    def __init__(self) -> None:
        self.times: list[float] = []

    def observe(self, ctx: StepContext) -> list[Any]:
        self.times.append(time.thread_time())  # the session thread's CPU: steady under load
        return []

    def finish(self, ctx: StepContext) -> list[Any]:
        return []


def scenario_step(record: bool, repeats: int) -> tuple[float, float, int]:
    """Per-step seconds of the sweep scenario's run (see the module docstring) and of a raw
    ``mj_step`` loop of its model, best of ``repeats``, and the steps per run."""
    data = yaml.safe_load(SWEEP.read_text(encoding="utf-8"))
    data.pop("explore", None)
    if not record:
        data["recording"] = {"enabled": False}
    clocks: list[_Clock] = []
    models: list[mujoco.MjModel] = []

    def clearance(session: Any) -> ClearanceLogger:
        model = session.model
        models.append(model)
        links = [v.mujoco_name(k.name) for v in session.world.robots for k in v.description.links]
        bodies = [b for b in links if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) > 0]
        return ClearanceLogger(model, robot_bodies=bodies, ignore=[("*", "box")], distmax=1.0)

    def clock(session: Any) -> _Clock:
        clocks.append(_Clock())
        return clocks[-1]

    runner = dataclasses.replace(
        session_iteration_runner(), chunk=1_000_000, watchers=(clearance, clock)
    )
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        file = Path(tmp) / "sweep.yaml"
        file.write_text(yaml.safe_dump(data), encoding="utf-8")
        spec = iteration_specs(load_run_file(file), Path(tmp))[0]
        for _ in range(repeats):
            clocks.clear()
            runner(spec)
            times = clocks[0].times
            best = min(best, (times[-1] - times[0]) / (len(times) - 1))
    steps = len(times)
    model = models[0]
    raw = mujoco.MjData(model)

    bare = float("inf")
    for _ in range(repeats):
        mujoco.mj_resetData(model, raw)
        start = time.thread_time()
        for _ in range(steps):
            mujoco.mj_step(model, raw)
        bare = min(bare, time.thread_time() - start)
    return best, bare / steps, steps


MIN_RATIO = 0.1
"""The bare step of the same scene over the step with every logger (measured 0.14-0.34 on a
loaded 2-core machine): with every logger a step may cost at most 10x the bare step."""


def run(quick: bool) -> list[Row]:
    steps, repeats = (500, 3) if quick else (2000, 7)
    rows = []
    for n in (0, 10, 100):
        bare_us, logged_us, ncon = measure(n, steps, repeats)
        overhead = logged_us - bare_us
        rows.append(
            Row(
                name=f"events: step + loggers, {ncon} contacts",
                ours=logged_us,
                limit=bare_us,
                unit="us",
                target=f"ratio >= {MIN_RATIO} (loggers <= {1 / MIN_RATIO:.1f}x the bare step)",
                passed=bare_us / logged_us >= MIN_RATIO,
                higher_is_better=False,
                note=f"overhead {overhead:.1f} us/step",
            )
        )
    for record in (False, True):
        ours, bare, steps = scenario_step(record, 3 if quick else 7)
        python_us = (ours - bare) * 1e6
        rows.append(
            Row(
                name="events: scenario run per step (sweep), recording "
                + ("on" if record else "off"),
                ours=ours * 1e6,
                limit=bare * 1e6,
                unit="us",
                target=f"<= {STEP_TARGET_US:.0f} us over mj_step (report)",
                passed=True,
                higher_is_better=False,
                note=f"{steps} steps; the run's own per step beyond mj_step: {python_us:.0f} us "
                "(controllers, loggers incl. clearance, recording, publishing)",
            )
        )
    return rows
