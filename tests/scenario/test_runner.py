"""The runner machinery: iterations on spawned local workers and on Dask, determinism,
failures as results, the reports written by a run, and `harness run`'s notices and errors."""

import dataclasses
import io
import json
import math
import sys
import xml.etree.ElementTree as ET

import pytest
import yaml
from rich.console import Console

from harness import cli
from harness.scenario import (
    LocalBackend,
    iteration_specs,
    load_run_file,
    run_iterations,
    run_scenarios,
)
from tests.scenario.scenario_testlib import CLIENT, EXAMPLES, gone_runner, process_gone
from tests.scenario.standins import ClientRunner, StepLoadRunner

PASSING = {
    "robots": [{"robot": "demo"}],
    "duration": 1.0,
    "criteria": {"allowed_collisions": [["obstacle", "forearm"]], "joint_limit_tolerance": 0.05},
}
FAILING = {"robots": [{"robot": "demo"}], "duration": 1.0}


def _write_run(tmp_path, simulations, scenarios):
    for name, doc in scenarios.items():
        (tmp_path / name).write_text(yaml.safe_dump(doc))
    (tmp_path / "run.yaml").write_text(yaml.safe_dump({"simulations": simulations}))
    return load_run_file(tmp_path / "run.yaml")


def _comparable(result):
    return dataclasses.replace(result, wall_seconds=0.0)


def test_iteration_specs_give_each_iteration_its_own_folder_recording_and_free_port(tmp_path):
    config = _write_run(
        tmp_path,
        [
            {"name": "a b/c", "scenario": "pass.yaml", "iterations": 2},
            {"name": "second", "scenario": "fail.yaml"},
        ],
        {"pass.yaml": PASSING, "fail.yaml": FAILING},
    )
    specs = iteration_specs(config, tmp_path / "out")
    assert [(s.simulation, s.iteration) for s in specs] == [
        ("a b/c", 1),
        ("a b/c", 2),
        ("second", 1),
    ]
    assert len({s.out_dir for s in specs}) == 3
    assert len({s.recording_path for s in specs}) == 3
    assert all(s.recording_path.parent == s.out_dir for s in specs)
    assert specs[0].out_dir == (tmp_path / "out" / "a-b-c" / "iteration-001").resolve()
    assert all(s.port == 0 for s in specs)
    assert [len(iteration_specs(config, tmp_path, iterations=4))] == [8]


@pytest.mark.slow
def test_local_workers_run_deterministic_iterations_and_judge_determinism(tmp_path):
    config = _write_run(
        tmp_path,
        [{"name": "det", "scenario": "pass.yaml", "iterations": 3}],
        {"pass.yaml": PASSING},
    )
    specs = iteration_specs(config, tmp_path / "out")
    seen = []
    results = run_iterations(StepLoadRunner(), specs, LocalBackend(2), True, seen.append)
    assert sorted(r.iteration for r in seen) == [1, 2, 3]
    assert [r.iteration for r in results] == [1, 2, 3]
    assert all(r.passed for r in results), [r.reason for r in results]
    assert len({r.state_digest for r in results}) == 1
    det = [v for r in results for v in r.verdicts if v.name == "determinism"]
    assert len(det) == 3
    assert all(v.passed for v in det)
    assert results[0].steps == 500
    assert results[0].collisions  # the stand-in arm touches its obstacle, allowed here


def test_determinism_failure_is_reported(tmp_path):
    from harness.scenario import judge_determinism

    config = _write_run(
        tmp_path, [{"name": "d", "scenario": "pass.yaml", "iterations": 2}], {"pass.yaml": PASSING}
    )
    specs = iteration_specs(config, tmp_path / "out")
    runner = StepLoadRunner(max_steps=50)
    a, b = (runner(s) for s in specs)
    b = dataclasses.replace(b, state_digest="0" * 64)
    ja, jb = judge_determinism([a, b])
    assert ja.verdicts[-1].passed
    assert not jb.verdicts[-1].passed
    assert "state stream differs from iteration 1" in jb.verdicts[-1].detail
    (single,) = judge_determinism([a])
    assert not single.passed


@pytest.mark.slow
def test_failures_are_results_and_reports_count_them(tmp_path):
    config = _write_run(
        tmp_path,
        [
            {"name": "good", "scenario": "pass.yaml", "iterations": 2},
            {"name": "bad", "scenario": "fail.yaml", "iterations": 2},
        ],
        {"pass.yaml": PASSING, "fail.yaml": FAILING},
    )
    out = tmp_path / "results"
    console = Console(record=True, width=200, file=io.StringIO())
    results = run_scenarios(config, StepLoadRunner(), LocalBackend(2), out, console)
    assert [r.passed for r in results] == [True, True, False, False]
    assert "collisions: 1 disallowed collision(s); first obstacle - forearm" in results[2].reason
    assert [v.name for v in results[2].verdicts] == ["collisions", "joint_limits"]

    root = ET.parse(out / "junit.xml").getroot()
    assert root.tag == "testsuites"
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("4", "2", "0")
    suites = {s.get("name"): s for s in root.findall("testsuite")}
    assert set(suites) == {"good", "bad"}
    assert suites["bad"].get("failures") == "2"
    assert suites["good"].get("failures") == "0"
    cases = suites["bad"].findall("testcase")
    assert [c.get("name") for c in cases] == ["iteration 1", "iteration 2"]
    failure = cases[0].find("failure")
    assert failure is not None
    assert failure.get("type") == "collisions"
    assert "collisions: 1 disallowed collision(s)" in failure.text
    assert suites["good"].find("testcase/failure") is None

    doc = json.loads((out / "results.json").read_text())
    assert doc["summary"] == {"iterations": 4, "passed": 2, "failed": 2}
    first = doc["results"][0]
    assert first["passed"] is True
    assert len(first["traces"]["time"]) == len(first["traces"]["joints"][0]["position"]) > 100
    assert (out / "report.html").is_file()

    text = console.export_text()
    assert "2/4 iterations passed" in text
    assert "FAIL" in text
    assert "PASS" in text


@pytest.mark.slow
def test_runner_exception_and_dead_worker_become_errors(tmp_path):
    config = _write_run(tmp_path, [{"name": "e", "scenario": "pass.yaml"}], {"pass.yaml": PASSING})
    (spec,) = iteration_specs(config, tmp_path / "out")
    broken = dataclasses.replace(spec, sim_time_limit=math.nan)
    (result,) = run_iterations(StepLoadRunner(), [broken], LocalBackend(1))
    assert not result.passed
    assert result.error.startswith("runner raised ValueError: cannot convert float NaN")
    (dead,) = run_iterations(gone_runner, [spec], LocalBackend(1))
    assert dead.error == "the worker process running it died"


@pytest.mark.slow
def test_clients_in_worker_processes_fail_with_reasons_and_leave_nothing(tmp_path):
    scenarios, simulations = {}, []
    for mode in ("crash", "noconnect", "ok"):
        pidfile = tmp_path / f"{mode}.pids"
        scenarios[f"{mode}.yaml"] = {
            **PASSING,
            "client": {
                "command": [sys.executable, str(CLIENT), mode, str(pidfile)],
                "readiness_timeout": 1.0,
                "wall_timeout": 30,
            },
        }
        simulations.append({"name": mode, "scenario": f"{mode}.yaml"})
    config = _write_run(tmp_path, simulations, scenarios)
    specs = iteration_specs(config, tmp_path / "out")
    crash, noconnect, ok = run_iterations(ClientRunner(grace=1.0), specs, LocalBackend(2))
    assert "client exited with code 3" in crash.reason
    assert "client did not connect" in noconnect.reason
    assert ok.passed, ok.reason
    assert crash.client.log_path == specs[0].out_dir / "client.log"
    assert {crash.port, ok.port}.isdisjoint({0, None})
    for mode in ("crash", "noconnect", "ok"):
        pids = [int(p) for p in (tmp_path / f"{mode}.pids").read_text().split()]
        assert all(process_gone(p) for p in pids)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_results_as_local_workers(tmp_path):
    distributed = pytest.importorskip("distributed", reason="optional Dask backend not installed")
    from harness.scenario import DaskBackend

    config = _write_run(
        tmp_path,
        [
            {"name": "p", "scenario": "pass.yaml", "iterations": 2},
            {"name": "f", "scenario": "fail.yaml", "iterations": 1},
        ],
        {"pass.yaml": PASSING, "fail.yaml": FAILING},
    )
    specs = iteration_specs(config, tmp_path / "out")
    runner = StepLoadRunner(max_steps=300)
    local = run_iterations(runner, specs, LocalBackend(2), check_determinism=True)
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = run_iterations(
            runner, specs, DaskBackend(cluster.scheduler_address), check_determinism=True
        )
    assert [_comparable(r) for r in remote] == [_comparable(r) for r in local]
    assert [r.passed for r in remote] == [True, True, False]


def test_harness_run_reports_config_errors_first(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("robots: [{robot: demo}]\ndurration: 3\n")
    assert cli.main(["run", str(bad)]) == 2
    assert "durration: unknown key (did you mean 'duration'?)" in capsys.readouterr().err
    assert cli.main(["run", str(EXAMPLES / "demo.yaml"), "--backend", "dask"]) == 2
    assert "--backend dask needs --scheduler ADDRESS" in capsys.readouterr().err


@pytest.mark.slow
def test_harness_run_prints_notices_for_ignored_original_keys(tmp_path, capsys):
    # The original runner config starts `ros2 launch ...`, not installed here: every iteration
    # fails with that reason (quickly), after the notices about the ignored keys.
    out = tmp_path / "o"
    assert cli.main(["run", str(EXAMPLES / "original-runner.json"), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "restartBridge: accepted and ignored" in err
    assert "ueProject: accepted and ignored" in err
    doc = json.loads((out / "results.json").read_text())
    assert doc["summary"] == {"iterations": 3, "passed": 0, "failed": 3}
    assert "client command 'ros2' could not start" in doc["results"][0]["reason"]
