"""Cold start with a xacro robot: a fresh interpreter loads the UR5e from its description
package's ``ur_mocked.urdf.xacro`` with arguments (import, xacro expansion, build, compile).

Judged against the same robot as a plain URDF (the expansion's output, same meshes through the
same ``packages`` map) loaded by a fresh interpreter in the same run; target: at most 1.3x.
Runs alternate between the two so that a busy machine slows both alike.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import Row

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "tests" / "data" / "descriptions" / "ur_description"
ENTRY = PACKAGE / "urdf" / "ur_mocked.urdf.xacro"
ARGS = {"ur_type": "ur5e", "name": "ur"}
LIMIT_RATIO = 1.3

CODE = (
    "import sys, json; from harness.models import load_robot; "
    "load_robot(sys.argv[1], robot_args=json.loads(sys.argv[2]), "
    "packages={'ur_description': sys.argv[3]})"
)


def _wall(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", CODE, *args], check=True, cwd=ROOT)
    return time.perf_counter() - start


def run(quick: bool) -> list[Row]:
    sys.path.insert(0, str(ROOT))
    from harness.models.xacro.expand import expand_xacro

    runs = 5 if quick else 15
    with tempfile.TemporaryDirectory(prefix="bench_xacro_") as folder:
        plain = Path(folder) / "ur5e.urdf"
        plain.write_bytes(expand_xacro(ENTRY, ARGS).urdf)
        xacro_args = [str(ENTRY), '{"ur_type": "ur5e", "name": "ur"}', str(PACKAGE)]
        urdf_args = [str(plain), "{}", str(PACKAGE)]
        _wall(xacro_args)  # warm the OS file cache and .pyc files
        _wall(urdf_args)
        ours_runs, limit_runs = [], []
        for _ in range(runs):
            ours_runs.append(_wall(xacro_args))
            limit_runs.append(_wall(urdf_args))
    ours, limit = statistics.median(ours_runs), statistics.median(limit_runs)
    ratio = ours / limit
    print(
        f"cold start UR5e: xacro {ours * 1e3:.0f} ms, plain URDF {limit * 1e3:.0f} ms, {ratio:.2f}x"
    )
    return [
        Row(
            name="cold start: xacro robot (UR5e, ur_type:=ur5e) vs same robot as URDF",
            ours=ours * 1e3,
            limit=limit * 1e3,
            unit="ms",
            target=f"<= {LIMIT_RATIO}x the URDF",
            passed=ratio <= LIMIT_RATIO,
            higher_is_better=False,
            note=f"median of {runs} alternating runs; expansion + import of xacro "
            f"{(ours - limit) * 1e3:.0f} ms",
        )
    ]
