"""``harness explore`` end to end on planted failures: real Sessions, real recordings.

Each planted failure must be found within the stated example budget; its minimal case must
fail under ``harness run``, its recording replay REPRODUCED, and test_minimal.py fail under
pytest. A scenario with no failure in range reports none and exits 0; a bad file exits 2.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from harness import cli
from harness.replay import verify
from tests.explore.conftest import DATA

ROOT = Path(__file__).resolve().parents[2]


def _harness(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "harness", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


def _check_minimal(out: Path, tmp_path: Path) -> dict:
    summary = json.loads((out / "summary.json").read_text())
    minimal = summary["minimal"]
    assert minimal["recordings_identical"] is True
    assert minimal["replay"] == "REPRODUCED"
    assert minimal["fails_under_harness_run"] is True
    assert "explore" not in yaml.safe_load((out / "minimal.yaml").read_text())
    # the minimal case fails under a cold `harness run`, from another folder
    run = _harness(
        "run",
        str(out / "minimal.yaml"),
        "--out",
        str(tmp_path / "cold"),
        "--workers",
        "1",
        cwd=tmp_path,
    )
    assert run.returncode == 1, run.stdout + run.stderr
    # its recording replays bit for bit
    assert verify(out / "minimal.mcap").reproduced
    # the regression test fails under pytest
    test = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            str(out / "test_minimal.py"),
            "-q",
            "-p",
            "no:cacheprovider",
        ],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert test.returncode == 1, test.stdout
    assert "1 failed" in test.stdout
    return summary


@pytest.mark.slow
def test_planted_obstacle_in_the_sweep_is_found_and_shrunk(tmp_path: Path) -> None:
    """Budget: 60 examples. The obstacle box is 1.0 x 1.2 m around the arm; the sweep's arc
    crosses it."""
    out = tmp_path / "out"
    code = cli.main(
        ["explore", str(DATA / "sweep.yaml"), "--examples", "60", "--out", str(out), "--seed", "1"]
    )
    assert code == 1
    summary = _check_minimal(out, tmp_path)
    minimal = summary["minimal"]
    assert "obstacle" in minimal["signature"]
    # shrinking moved toward the scenario as written: the last step of the path is the
    # minimal case, no farther from the nominal than the first failure found
    path = minimal["shrink_path"]
    assert path[-1] == minimal["parameters"]
    nominal = minimal["nominal"]["objects.obstacle.position"]
    first = summary["signatures"][minimal["signature"]]["first"]["objects.obstacle.position"]
    final = minimal["parameters"]["objects.obstacle.position"]
    assert final[2] == first[2] == nominal[2] == 0.5  # the fixed component stays fixed
    html = (out / "report.html").read_text()
    assert "<svg" in html
    assert "objects.obstacle.position[0]" in html


@pytest.mark.slow
def test_planted_two_parameter_client_bug_is_found(tmp_path: Path) -> None:
    """Budget: 20 examples (6 combinations). Only TARGET_X 0.3 with MODE fast fails."""
    out = tmp_path / "out"
    code = cli.main(["explore", str(DATA / "reach.yaml"), "--examples", "20", "--out", str(out)])
    assert code == 1
    summary = _check_minimal(out, tmp_path)
    assert summary["minimal"]["parameters"] == {
        "client.env.TARGET_X": "0.3",
        "client.env.MODE": "fast",
    }
    runs = [json.loads(line) for line in (out / "examples.jsonl").read_text().splitlines()]
    failing = {
        (r["values"]["client.env.TARGET_X"], r["values"]["client.env.MODE"])
        for r in runs
        if not r["passed"]
    }
    assert failing == {("0.3", "fast")}


@pytest.mark.slow
def test_planted_mobile_overshoot_above_a_speed_is_found(tmp_path: Path) -> None:
    """Budget: 10 examples (5 speeds). The controller stops by odometry without a braking
    distance: at 0.5 m/s it overshoots into the wall; 0.1-0.4 m/s stop short of it."""
    out = tmp_path / "out"
    code = cli.main(["explore", str(DATA / "approach.yaml"), "--examples", "10", "--out", str(out)])
    assert code == 1
    summary = _check_minimal(out, tmp_path)
    assert summary["minimal"]["parameters"] == {"client.env.SPEED": "0.5"}
    assert "wall" in summary["minimal"]["signature"]
    runs = [json.loads(line) for line in (out / "examples.jsonl").read_text().splitlines()]
    assert {r["values"]["client.env.SPEED"] for r in runs if not r["passed"]} == {"0.5"}


def test_no_failure_in_range_exits_0(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code = cli.main(["explore", str(DATA / "clear.yaml"), "--examples", "6", "--out", str(out)])
    assert code == 0
    err = capsys.readouterr().err
    assert "no failure in 6 examples" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failures_found"] == 0
    assert summary["minimal"] is None
    assert not (out / "minimal.yaml").exists()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        ({"explore": None}, "has no explore section"),
        (
            {"explore": {"parameters": {"objects.nope.size": {"low": [1], "high": [2]}}}},
            "explore.parameters.objects.nope.size: objects has no entry named 'nope'",
        ),
        (
            {"explore": {"parameters": {"seed": {"integers": [0, 1]}}, "target": "closeness"}},
            "explore.target",
        ),
    ],
)
def test_bad_file_exits_2_with_one_line(tmp_path: Path, edit: dict, message: str) -> None:
    doc = yaml.safe_load((DATA / "sweep.yaml").read_text())
    for key, value in edit.items():
        if value is None:
            doc.pop(key)
        else:
            doc[key] = value
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc))
    result = _harness("explore", str(path), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("harness explore: error: ")
    assert "bad.yaml" in lines[0]
    assert message in lines[0]


@pytest.mark.slow
def test_dask_backend_runs_one_engine_per_worker(tmp_path: Path) -> None:
    """Two engines as tasks on two local ``dask worker`` processes (127.0.0.1): each runs its
    share with its own seed; nothing in range fails, so both run to their budget."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=0,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    ) as cluster:
        address = cluster.scheduler_address
        command = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host",
                   "127.0.0.1", "--nthreads", "1", "--no-nanny", "--no-dashboard"]  # fmt: skip
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        workers = [
            subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(2)
        ]
        try:
            with distributed.Client(address) as client:
                client.wait_for_workers(2, timeout=120)
            out = tmp_path / "out"
            code = cli.main(
                ["explore", str(DATA / "clear.yaml"), "--examples", "4", "--workers", "2",
                 "--backend", "dask", "--scheduler", address, "--out", str(out)]
            )  # fmt: skip
        finally:
            for worker in workers:
                worker.terminate()
                worker.wait(timeout=30)
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert [(e["worker"], e["seed"], e["examples"]) for e in summary["engines"]] == [
        (0, 0, 2),
        (1, 1, 2),
    ]
