"""Real robots: load and check-model time per robot of example-robot-data (issue 14).

Per robot, in the same run: ``load_robot`` (warm mesh cache: the first pass converts meshes)
and ``check_model`` (load + 10 s hold + a step per joint + kinematic hold), each against a
bare ``MjSpec.compile()`` of the same compiled model (the floor any loader stands on).
Reports the median and the worst robot.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

from common import Row

from tests.models.paths import robots_dir

ROOT = Path(__file__).resolve().parents[1]


def _seconds(fn: object) -> float:
    start = time.perf_counter()
    fn()  # type: ignore[operator]
    return time.perf_counter() - start


def run(quick: bool) -> list[Row]:
    sys.path.insert(0, str(ROOT))
    from harness.errors import HarnessError
    from harness.models import load_robot
    from harness.models.check.report import check_model

    warnings.simplefilter("ignore")  # the loader's notes and MuJoCo's attach notice
    urdfs = sorted(robots_dir().rglob("*.urdf"))
    if quick:
        urdfs = urdfs[::6]
    cache = Path(tempfile.mkdtemp(prefix="bench_robots_"))
    loads: list[tuple[float, str]] = []
    checks: list[tuple[float, str]] = []
    bare: dict[str, float] = {}
    for path in urdfs:
        name = str(path.relative_to(robots_dir()))
        try:
            loaded = load_robot(path, cache_dir=cache)  # converts meshes once
        except HarnessError:
            continue
        bare[name] = min(_seconds(loaded.spec.compile) for _ in range(3))
        loads.append(
            (min(_seconds(lambda p=path: load_robot(p, cache_dir=cache)) for _ in range(2)), name)
        )
        checks.append((_seconds(lambda p=path: check_model(p, cache_dir=cache)), name))
    limit = statistics.median(bare.values())
    load_median = statistics.median(t for t, _ in loads)
    load_worst = max(loads)
    check_median = statistics.median(t for t, _ in checks)
    check_worst = max(checks)
    print(
        f"robots: {len(loads)} loaded; load median {load_median * 1e3:.0f} ms, worst "
        f"{load_worst[0] * 1e3:.0f} ms ({load_worst[1]}); check-model median "
        f"{check_median:.2f} s, worst {check_worst[0]:.2f} s ({check_worst[1]}); bare compile "
        f"median {limit * 1e3:.1f} ms, slowest {max(bare.values()) * 1e3:.1f} ms"
    )
    return [
        Row(
            name=f"robots: load_robot per robot, median of {len(loads)} (vs bare MjSpec compile)",
            ours=load_median * 1e3,
            limit=limit * 1e3,
            unit="ms",
            target="report",
            passed=True,
            higher_is_better=False,
            note="self-collision sampling, placement, gains and two compiles",
        ),
        Row(
            name="robots: load_robot, worst robot (vs its own bare compile)",
            ours=load_worst[0] * 1e3,
            limit=bare[load_worst[1]] * 1e3,
            unit="ms",
            target="report",
            passed=True,
            higher_is_better=False,
            note=load_worst[1],
        ),
        Row(
            name="robots: check-model per robot, median (load + 10 s hold + steps)",
            ours=check_median * 1e3,
            limit=limit * 1e3,
            unit="ms",
            target="report",
            passed=True,
            higher_is_better=False,
        ),
        Row(
            name="robots: check-model, worst robot (vs its own bare compile)",
            ours=check_worst[0] * 1e3,
            limit=bare[check_worst[1]] * 1e3,
            unit="ms",
            target="report",
            passed=True,
            higher_is_better=False,
            note=check_worst[1],
        ),
    ]
