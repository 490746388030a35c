"""`harness run --backend dask` with a worker that cannot see the client's files.

The worker is a real ``dask worker`` process in its own mount namespace with a private tmpfs
over this pytest run's temporary root (``unshare --mount``; the test runs as root), while the
scenario, robot (URDF in a ROS package with an STL and a COLLADA mesh), world (MJCF with a mesh
and a texture) and client script live there on the client's side, and so does ``--out``. Only
that folder is hidden: the worker's Python and the project stay visible wherever they are
installed (a clone under /tmp included). The scheduler and the worker
bind 127.0.0.1. The results must equal those of local workers (verdicts, state digests, the
recordings byte for byte), the recordings come back into ``--out``, and each file travels to
the worker once.
"""

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from rich.console import Console

import harness
from harness.recording import Recording
from harness.replay import verify
from harness.scenario import (
    DaskBackend,
    LocalBackend,
    iteration_specs,
    load_run_file,
    run_iterations,
    run_scenarios,
    session_iteration_runner,
)
from harness.scenario.errors import RunnerError

distributed = pytest.importorskip("distributed", reason="optional Dask backend not installed")

DATA = Path(__file__).resolve().parents[1] / "data"
MESHES = DATA / "models" / "mesh_arm"
LOCKSTEP = DATA / "scenario" / "clients" / "lockstep.py"
URDF = """<?xml version="1.0"?>
<robot name="remote_arm">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <collision><geometry><mesh filename="package://remote_arm/meshes/base.dae"/></geometry>
    </collision>
  </link>
  <link name="arm">
    <inertial><origin xyz="0 0 0.15"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0 0 0.1"/>
      <geometry><mesh filename="package://remote_arm/meshes/link.stl"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <origin xyz="0 0 0.3"/><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" velocity="5" effort="50"/>
  </joint>
</robot>
"""
PACKAGE_XML = """<?xml version="1.0"?>
<package format="3"><name>remote_arm</name><version>0.0.0</version>
<description>test</description><maintainer email="a@b.c">t</maintainer>
<license>BSD</license></package>
"""
STATE_TOPICS = ("/harness/state", "/harness/inputs", "/joint_states")


def _unshare_works() -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c", "mount -t tmpfs t /mnt"],
        capture_output=True,
    )
    return probe.returncode == 0


def _client_files(root: Path) -> Path:
    """Scenario, ROS package, world and client script under ``root``; the scenario's path."""
    package = root / "ws" / "remote_arm"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    (package / "urdf" / "arm.urdf").write_text(URDF)
    (package / "package.xml").write_text(PACKAGE_XML)
    shutil.copy(MESHES / "meshes" / "base.dae", package / "meshes")
    shutil.copy(MESHES / "meshes" / "link.stl", package / "meshes")
    world = root / "world"
    shutil.copytree(MESHES / "meshes", world / "meshes")
    shutil.copytree(MESHES / "textures", world / "textures")
    shutil.copy(MESHES / "scene.xml", world)
    (root / "scenarios" / "clients").mkdir(parents=True)
    shutil.copy(LOCKSTEP, root / "scenarios" / "clients")
    scenario = root / "scenarios" / "remote.yaml"
    doc = {
        "robots": [
            {
                "robot": "../ws/remote_arm/urdf/arm.urdf",
                "position": [0, 0, 0.05],
                "subscribers": [{"type": "JointStateSubscriber", "topic": "/arm/cmd"}],
            }
        ],
        "environment": {"map": "../world/scene.xml"},
        "duration": 0.2,
        "clock": {"mode": "lockstep"},
        "criteria": {"no_collisions": False},
        "client": {
            "command": ["python", "clients/lockstep.py", "0.2", "shoulder", "/arm/cmd"],
            "readiness_timeout": 30,
        },
    }
    scenario.write_text(yaml.safe_dump(doc))
    return scenario


def _stream_digest(path: Path) -> str:
    h = hashlib.sha256()
    with Recording(path) as rec:
        for m in rec.messages(STATE_TOPICS):
            h.update(f"{m.topic}\0{m.sim_time_ns}\0".encode() + m.data)
        h.update(rec.all_metadata["harness"]["model_sha256"].encode())
    return h.hexdigest()


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same(result):
    # The client verdict's detail says which came first, the client's exit or the sim-time
    # limit: a wall-clock race on any backend, so only its outcome is compared.
    verdicts = tuple(
        (v.name, v.passed) if v.name == "client" else (v.name, v.passed, v.detail)
        for v in result.verdicts
    )
    return (result.simulation, result.iteration, verdicts, result.steps, result.state_digest)


@pytest.fixture
def isolated_worker(tmp_path, tmp_path_factory):
    """A scheduler on 127.0.0.1 and one worker process that cannot see this run's
    temporary folders (a private tmpfs over their root, where its own caches live too)."""
    if not _unshare_works():
        pytest.skip("unshare --mount with a private tmpfs is not permitted here")
    hidden = tmp_path_factory.getbasetemp().resolve()
    if hidden.parent.name.startswith("pytest-"):  # pytest-of-<user>/pytest-N[/popen-gwK]
        hidden = hidden.parent if hidden.name.startswith("popen-") else hidden
    project = Path(harness.__file__).resolve().parents[1]
    if project.is_relative_to(hidden) or Path(sys.executable).is_relative_to(hidden):
        pytest.skip(f"the project lies inside the folder the worker must not see ({hidden})")
    env = {
        **os.environ,
        "PYTHONPATH": str(project),
        "HARNESS_CACHE_DIR": str(hidden / "worker-meshes"),  # inside the private tmpfs
        "HARNESS_WORKER_DIR": str(hidden / "worker-files"),
    }
    with distributed.LocalCluster(
        n_workers=0,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    ) as cluster:
        worker = subprocess.Popen(
            [
                "unshare",
                "--mount",
                "--propagation",
                "private",
                "sh",
                "-c",
                'mount -t tmpfs -o size=512m harness-worker "$0" && cd / && exec "$@"',
                str(hidden),
                sys.executable,
                "-m",
                "distributed.cli.dask_worker",
                cluster.scheduler_address,
                "--host",
                "127.0.0.1",
                "--nthreads",
                "1",
                "--nworkers",
                "1",
                "--no-dashboard",
                "--no-nanny",
            ],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=(tmp_path / "worker.log").open("w"),
        )
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
                client.wait_for_workers(1, timeout=60)
                yield cluster.scheduler_address, client
        finally:
            worker.terminate()
            try:
                worker.wait(timeout=20)
            except subprocess.TimeoutExpired:
                worker.kill()
                worker.wait()


@pytest.mark.slow
def test_a_worker_without_the_clients_files_gives_the_same_results_as_local_workers(
    tmp_path, isolated_worker
):
    address, client = isolated_worker
    scenario = _client_files(tmp_path / "client")
    # The worker cannot see the client's files, nor the folder the results go to.
    seen = client.run(os.path.exists, str(scenario))
    assert list(seen.values()) == [False]
    assert list(client.run(os.path.exists, str(tmp_path)).values()) == [False]

    config = load_run_file(scenario)
    runner = session_iteration_runner()
    local = run_iterations(
        runner, iteration_specs(config, tmp_path / "local", 2), LocalBackend(1), True
    )
    out = tmp_path / "out"
    backend = DaskBackend(address)
    with (tmp_path / "summary.txt").open("w") as text:
        console = Console(file=text, width=200)
        remote = run_scenarios(config, runner, backend, out, console, 2, check_determinism=True)

    assert [r.error for r in local + remote] == [None] * 4
    assert [_same(r) for r in remote] == [_same(r) for r in local]
    assert all(r.passed for r in remote), [r.reason for r in remote]
    assert {v.name for v in remote[0].verdicts} >= {"client", "determinism", "joint_limits"}
    assert remote[0].steps == 100
    # The client under test ran on the worker (its script travelled) and stepped the world.
    assert remote[0].client.passed
    assert remote[0].client.status in ("exited", "sim_limit")
    (trace,) = remote[0].traces.joints
    assert max(trace.command) > 0.3  # the client's commands reached the worker's session
    for r, ref in zip(remote, local, strict=True):
        # The recording came back into --out, with the client's paths in the result.
        assert r.recording == out / "remote" / f"iteration-{r.iteration:03d}" / "recording.mcap"
        assert r.recording.is_file()
        assert r.client.log_path is not None
        assert r.client.log_path.is_file()
        assert r.client.log_path.parent == r.recording.parent
        # Same physics, same inputs, same joint states, same compiled model as a local worker.
        assert _stream_digest(r.recording) == _stream_digest(ref.recording)
        # ... and, the client being lockstep, the same recording byte for byte.
        assert _sha256(r.recording) == _sha256(ref.recording)
    assert verify(remote[1].recording).reproduced
    doc = json.loads((out / "results.json").read_text())
    assert [Path(d["recording"]) for d in doc["results"]] == [r.recording for r in remote]

    # Each file crossed once: the second iteration's worker had them all in its cache.
    files = {f.path for f in _bundle_of(config)}
    assert str(scenario) in files
    assert str(tmp_path / "client" / "ws" / "remote_arm" / "meshes" / "base.dae") in files
    assert str(tmp_path / "client" / "ws" / "remote_arm" / "package.xml") in files
    assert str(tmp_path / "client" / "world" / "textures" / "checker.png") in files
    assert str(tmp_path / "client" / "scenarios" / "clients" / "lockstep.py") in files
    log = backend.transfers
    assert log.sent_files == len({f.sha256 for f in _bundle_of(config)})
    ((worker, (fetched, _)),) = log.fetched.items()
    assert worker.startswith("tcp://127.0.0.1:")
    assert fetched == log.sent_files
    assert log.recording_bytes == sum(r.recording.stat().st_size for r in remote)
    summary = (tmp_path / "summary.txt").read_text()
    assert f"dask: scattered {log.sent_files} file(s)" in summary
    assert "1 worker(s) fetched" in summary
    assert "(recordings " in summary


def _bundle_of(config):
    from harness.scenario.bundle import collect_bundle

    (spec,) = iteration_specs(config, Path("/nonexistent"), 1)
    bundle, _ = collect_bundle(spec)
    return bundle.files


def test_a_world_that_does_not_load_fails_its_iterations_and_no_worker_is_a_clear_error(
    tmp_path,
):
    scenario = _client_files(tmp_path / "client")
    broken = scenario.parent.parent / "ws" / "remote_arm" / "urdf" / "broken.urdf"
    broken.write_text("<robot name='broken'><link name='a'></robot>")
    doc = yaml.safe_load(scenario.read_text())
    doc["robots"][0]["robot"] = "../ws/remote_arm/urdf/broken.urdf"
    scenario.write_text(yaml.safe_dump(doc))
    (spec,) = iteration_specs(load_run_file(scenario), tmp_path / "out", 1)
    runner = session_iteration_runner()
    options = {
        "processes": False,
        "protocol": "tcp://",
        "host": "127.0.0.1",
        "dashboard_address": "127.0.0.1:0",
    }
    with distributed.LocalCluster(n_workers=0, **options) as cluster:
        backend = DaskBackend(cluster.scheduler_address, worker_timeout=0.5)
        with pytest.raises(RunnerError, match=r"no Dask worker joined the scheduler at tcp://"):
            backend.run(runner, [spec], lambda r: None)
    with distributed.LocalCluster(n_workers=1, **options) as cluster:
        backend = DaskBackend(cluster.scheduler_address)
        (result,) = backend.run(runner, [spec], lambda r: None)
    # Its files were not sent: the iteration failed on the client, naming the robot file.
    assert result.error.startswith("the files of the iteration could not be gathered: ")
    assert "broken.urdf" in result.error
    assert backend.transfers.sent_files == 0
