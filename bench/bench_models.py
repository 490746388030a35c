"""Cold start: a fresh interpreter imports harness.models, loads the demo robot and compiles it.

Judged against a bare interpreter that only imports mujoco and compiles the same model from
an MJCF string (the floor any loader stands on), measured in the same run; target: at most
twice the floor (ratio >= 0.5), whatever the machine. Printed beside the original framework's
start-up per run (Unreal 6.0-6.8 s, Gazebo 3.0-3.4 s, thesis table 5.4).
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import Row

ROOT = Path(__file__).resolve().parents[1]

OURS = "from harness.models import load_robot; load_robot('demo')"
LIMIT = "import sys, mujoco; mujoco.MjModel.from_xml_string(open(sys.argv[1]).read())"
MIN_RATIO = 0.5
"""Cold start may take at most twice the bare ``import mujoco`` + compile of the same model."""
UNREAL = (6.0, 6.8)
GAZEBO = (3.0, 3.4)


def _median_wall(code: str, args: list[str], runs: int) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", code, *args], check=True, cwd=ROOT)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run(quick: bool) -> list[Row]:
    sys.path.insert(0, str(ROOT))
    from harness.models import load_robot

    folder = tempfile.mkdtemp(prefix="bench_models_")
    mjcf = Path(folder) / "demo_compiled.xml"
    mjcf.write_text(load_robot("demo").mjcf)
    runs = 5 if quick else 15
    _median_wall(OURS, [], 1)  # warm the OS file cache and .pyc files
    ours = _median_wall(OURS, [], runs)
    limit = _median_wall(LIMIT, [str(mjcf)], runs)
    note = (
        f"original framework per run: Unreal {UNREAL[0]}-{UNREAL[1]} s "
        f"({UNREAL[0] / ours:.0f}x slower), Gazebo {GAZEBO[0]}-{GAZEBO[1]} s "
        f"({GAZEBO[0] / ours:.0f}x slower)"
    )
    shutil.rmtree(folder, ignore_errors=True)
    print(f"cold start: ours {ours * 1e3:.0f} ms, bare mujoco {limit * 1e3:.0f} ms; {note}")
    return [
        Row(
            name="cold start: import + load_robot('demo') + compile",
            ours=ours * 1e3,
            limit=limit * 1e3,
            unit="ms",
            target=f"ratio >= {MIN_RATIO} (<= {1 / MIN_RATIO:g}x bare mujoco)",
            passed=limit / ours >= MIN_RATIO,
            higher_is_better=False,
            note=note,
        )
    ]
