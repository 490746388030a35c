"""The session-backed iteration runner end to end: real Sessions on 127.0.0.1, real client
processes speaking rosbridge, real recordings read back and replayed."""

import dataclasses
import json
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

from harness import cli
from harness.recording import Recording
from harness.replay import verify
from harness.scenario import (
    LocalBackend,
    Scenario,
    iteration_specs,
    load_run_file,
    run_iterations,
    session_iteration_runner,
)
from harness.scenario.runfile import SimulationPlan
from tests.scenario.scenario_testlib import CLIENT, DATA, process_gone

LOCKSTEP = DATA / "clients" / "lockstep.py"
TWO_LINK = DATA / "robots" / "two_link.urdf"


def _scenario(tmp_path, name="s.yaml", **overrides):
    doc = {
        "robots": [
            {
                "robot": str(TWO_LINK),
                "subscribers": [{"type": "JointStateSubscriber", "topic": "/arm/cmd"}],
            }
        ],
        "environment": {"map": "empty"},
        "duration": 0.5,
        "clock": {"mode": "lockstep"},
        **overrides,
    }
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc))
    return path


def _pids(path: Path) -> list[int]:
    return [int(p) for p in path.read_text().split()]


@pytest.mark.slow
def test_harness_run_with_a_client_two_workers_and_determinism(tmp_path):
    client = [sys.executable, str(LOCKSTEP), "0.5", "shoulder", "/arm/cmd"]
    scenario = _scenario(tmp_path, client={"command": client, "readiness_timeout": 20})
    out = tmp_path / "out"
    code = cli.main(
        [
            "run",
            str(scenario),
            "--iterations",
            "2",
            "--workers",
            "2",
            "--check-determinism",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    root = ET.parse(out / "junit.xml").getroot()
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("2", "0", "0")
    doc = json.loads((out / "results.json").read_text())
    first, second = doc["results"]
    assert first["state_digest"] == second["state_digest"] is not None
    assert first["steps"] == 250
    assert {v["name"] for v in first["verdicts"]} >= {"client", "determinism", "joint_limits"}
    # The trace carries the commands the client published on its topic, through the bridge.
    (trace,) = first["traces"]["joints"]
    assert trace["joint"] == "shoulder"
    assert max(trace["command"]) == pytest.approx(0.5, abs=0.01)
    assert max(trace["position"]) > 0.3
    assert "<svg" in (out / "report.html").read_text()
    recording = Path(first["recording"])
    assert recording.is_file()
    with Recording(recording) as rec:
        frames = [f for f in rec.bridge_frames() if f.direction == 0]
        assert any(f.op == "publish" and f.topic == "/arm/cmd" for f in frames)
        assert sum(f.op == "call_service" for f in frames) == 25
    assert verify(recording).reproduced


@pytest.mark.slow
def test_clients_that_crash_hang_or_never_connect_fail_on_time_and_leave_nothing(tmp_path):
    runner = dataclasses.replace(session_iteration_runner(), grace=1.0)
    plans = []
    for mode, wall in (("crash", 30), ("noconnect", 30), ("hang", 2), ("stubborn", 2)):
        pidfile = tmp_path / f"{mode}.pids"
        path = _scenario(
            tmp_path,
            f"{mode}.yaml",
            client={
                "command": [sys.executable, str(CLIENT), mode, str(pidfile)],
                "readiness_timeout": 2,
                "wall_timeout": wall,
            },
        )
        scenario = Scenario.load(path)
        plans.append(SimulationPlan(mode, scenario, 1, scenario.client, 0.5))
    config = dataclasses.replace(load_run_file(_scenario(tmp_path)), simulations=tuple(plans))
    specs = iteration_specs(config, tmp_path / "out")
    crash, noconnect, hang, stubborn = run_iterations(runner, specs, LocalBackend(2))
    assert "client: client exited with code 3" in crash.reason
    assert "simulated failure" in crash.reason  # the client's last output
    assert "client did not connect to ws://127.0.0.1:" in noconnect.reason
    assert "within 2 s" in noconnect.reason
    assert "wall-time limit 2 s" in hang.reason
    assert "wall-time limit 2 s" in stubborn.reason  # ignores SIGTERM: killed after the grace
    for result, limit in ((crash, 10), (noconnect, 10), (hang, 10), (stubborn, 12)):
        assert result.error is None
        assert result.client.wall_seconds < limit
        assert result.steps == 0  # lockstep: nobody stepped
        assert result.recording.is_file()
    for mode in ("crash", "noconnect", "hang", "stubborn"):
        assert all(process_gone(p) for p in _pids(tmp_path / f"{mode}.pids")), mode


@pytest.mark.slow
def test_fast_clock_steps_only_once_a_client_connected_and_stops_at_the_limit(tmp_path):
    runner = session_iteration_runner()
    results = {}
    for mode in ("noconnect", "hang"):
        path = _scenario(
            tmp_path,
            f"{mode}.yaml",
            clock={"mode": "fast"},
            client={
                "command": [sys.executable, str(CLIENT), mode, str(tmp_path / f"{mode}.pids")],
                "readiness_timeout": 1.5,
                "wall_timeout": 30,
            },
        )
        (spec,) = iteration_specs(load_run_file(path), tmp_path / mode)
        results[mode] = runner(spec)
    assert results["noconnect"].steps == 0
    assert "did not connect" in results["noconnect"].reason
    hang = results["hang"]
    assert hang.steps == 250  # exactly the 0.5 s limit at 2 ms
    assert hang.client.status == "sim_limit"
    assert hang.passed, hang.reason


def test_without_a_client_the_duration_is_stepped_and_the_world_is_built(tmp_path):
    path = _scenario(
        tmp_path,
        duration=0.2,
        timestep=0.001,
        objects=[
            {"name": "ball", "shape": "sphere", "size": [0.03], "position": [0.5, 0, 0.5]},
            {"name": "crate", "shape": "box", "size": [0.05, 0.05, 0.05], "position": [0.3, 0, 1]},
        ],
        criteria={"no_collisions": False},
    )
    doc = yaml.safe_load(path.read_text())
    doc["objects"][1]["mass"] = 0.2
    doc["robots"][0]["initial_joint_positions"] = {"shoulder": 0.4}
    doc["robots"][0]["position"] = [0.1, 0.2, 0.0]
    path.write_text(yaml.safe_dump(doc))
    (spec,) = iteration_specs(load_run_file(path), tmp_path / "out")
    result = session_iteration_runner()(spec)
    assert result.passed, result.reason
    assert result.client is None
    assert result.steps == 200  # 0.2 s at the scenario's 1 ms timestep
    assert result.traces.joints[0].position[0] == pytest.approx(0.4)
    with Recording(result.recording) as rec:
        assert rec.timestep_ns == 1_000_000
        states = list(rec.physics_states())
        scene = rec.attachment("source/scene/scene.xml").decode()
    assert 'name="ball"' in scene
    assert 'name="crate"' in scene
    # The scene's crate (free joint: 7) comes before the shoulder; it falls under gravity.
    assert len(states[0].qpos) == 8
    assert states[0].qpos[7] == pytest.approx(0.4)
    assert states[-1].qpos[2] < states[0].qpos[2] - 0.1
    assert verify(result.recording).reproduced


@pytest.mark.slow
def test_original_framework_configs_run_end_to_end(tmp_path):
    runner = session_iteration_runner()
    config = load_run_file(DATA / "runner.json")
    (plan,) = config.simulations
    assert plan.client.command == (
        "ros2",
        "launch",
        "moveit2_tutorials",
        "pick_place_demo.launch.py",
    )
    tiny = dataclasses.replace(
        plan.client, command=(sys.executable, str(CLIENT), "ok", str(tmp_path / "pids"))
    )
    number = dataclasses.replace(plan, client=tiny, sim_time_limit=0.1, iterations=1)
    string_port = Scenario.load(DATA / "config_port_string.json")
    assert string_port.bridge.port == 9091
    string_plan = SimulationPlan("port as string", string_port, 1, None, 0.1)
    config = dataclasses.replace(config, simulations=(number, string_plan))
    first, second = run_iterations(
        runner, iteration_specs(config, tmp_path / "out"), LocalBackend(2)
    )
    assert first.error is None, first.error
    assert first.client.passed, first.client.reason
    assert first.recording.is_file()
    # config.json: Seq logging enabled towards a server that is not there: noted, not fatal.
    assert any("seq" in note for note in first.notes)
    assert second.error is None, second.error
    assert second.steps == 50
    # The demo arm placed at x = 0.5 m stands in the table: the position is honoured.
    assert any("table" in (c.body1, c.body2) for c in second.collisions)
    assert not second.passed


def test_scenarios_the_runner_cannot_run_are_refused_with_the_key_path(tmp_path, capsys):
    two = _scenario(tmp_path, "two.yaml")
    doc = yaml.safe_load(two.read_text())
    doc["robots"].append(
        {
            "robot": "demo",
            "name": "second",
            "modes": [{"type": "JointController", "mode": "kinematic", "beyond_limits": "allow"}],
        }
    )
    doc["robots"][0]["subscribers"].append(
        {"type": "JointTrajectorySubscriber", "topic": "/arm/trajectory"}
    )
    two.write_text(yaml.safe_dump(doc))
    assert cli.main(["run", str(two), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "robots[1].modes: 'allow' differs from robots[0]'s kinematic_limits" in err
    assert (
        "robots[0].subscribers[1].topic: '/arm/trajectory' is not served: trajectories are "
        "taken on '/two_link/joint_trajectory' only"
    ) in err
    assert not (tmp_path / "o").exists()


def test_unknown_initial_joint_is_a_config_error_with_the_key_path(tmp_path):
    from harness.scenario.world import build_world

    path = _scenario(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["robots"][0]["initial_joint_positions"] = {"elbow": 1.0}
    doc["robots"][0]["position"] = [1, 0, 0]
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(Exception, match=r"robots\[0\]\.initial_joint_positions\.elbow: 1\.0"):
        build_world(Scenario.load(path), tmp_path)


def _comparable(result):
    # Everything but wall time and the free port each session bound.
    return dataclasses.replace(result, wall_seconds=0.0, port=None)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_results_as_local_workers(tmp_path):
    distributed = pytest.importorskip("distributed", reason="optional Dask backend not installed")
    from harness.scenario import DaskBackend

    path = _scenario(tmp_path, duration=0.2)
    doc = yaml.safe_load(path.read_text())
    doc["robots"][0]["initial_joint_positions"] = {"shoulder": 1.55}  # beyond its 1.5 limit
    path.write_text(yaml.safe_dump(doc))
    config = load_run_file(path)
    runner = session_iteration_runner()
    local = run_iterations(
        runner, iteration_specs(config, tmp_path / "local", 2), LocalBackend(2), True
    )
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        remote = run_iterations(
            runner,
            iteration_specs(config, tmp_path / "local", 2),
            DaskBackend(cluster.scheduler_address),
            True,
        )
    assert [_comparable(r) for r in remote] == [_comparable(r) for r in local]
    assert local[0].state_digest == local[1].state_digest
    assert not local[0].passed
    assert "joint_limits: 1 joint(s) beyond limits; worst shoulder" in local[0].reason


def test_realtime_clock_is_paced_to_wall_time(tmp_path):
    path = _scenario(tmp_path, duration=0.4, clock={"mode": "realtime", "rate": 2.0})
    (spec,) = iteration_specs(load_run_file(path), tmp_path / "out")
    result = session_iteration_runner()(spec)
    assert result.passed, result.reason
    assert result.steps == 200
    # 0.4 s of simulation at twice real time cannot take less than 0.2 s of wall time.
    assert result.wall_seconds >= 0.2
