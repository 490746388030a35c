"""Logger overhead per step with 0, 10 and 100 active contacts, against the bare step.

The scene: N spheres resting on a plane (one contact each; N = 0 keeps one sphere in the air),
settled first. Measured in the same run: a raw ``mj_step`` loop of the same model (the limit),
and ``mj_step`` + ``extract_contacts`` + ``EventHub.observe`` with a CollisionLogger (every
step), a JointLimitLogger (every step) and a JointLogger at 100 Hz into a collecting sink.
"""

from __future__ import annotations

import mujoco
from common import Row, best_of

from harness.events import (
    CollectingSink,
    CollisionLogger,
    EventHub,
    JointLimitLogger,
    JointLogger,
    StepContext,
)
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
    return rows
