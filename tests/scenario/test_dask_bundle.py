"""The file bundle of the Dask backend, without Dask: every file a world reads is found, the
tree a worker materialises is enough once the client's files are gone, and the spec's paths
are rewritten into it."""

import dataclasses
import hashlib
import shutil
import sys
from pathlib import Path

import pytest
import yaml

from harness.scenario import iteration_specs, load_run_file
from harness.scenario.bundle import (
    BlobStore,
    bundle_env,
    collect_bundle,
    localise_spec,
    materialise,
    mirror,
    rewrite_paths,
)
from harness.scenario.errors import RunnerError
from harness.scenario.world import build_world

DATA = Path(__file__).resolve().parents[1] / "data"


def _cell(root: Path) -> Path:
    """A xacro robot from a ROS package (``package://``, ``$(find)``, includes, meshes), an SDF
    world with a ``model://`` include found through GZ_SIM_RESOURCE_PATH, a client script."""
    shutil.copytree(DATA / "descriptions" / "ur_description", root / "ws" / "ur_description")
    shutil.copytree(DATA / "worlds" / "crate", root / "models" / "crate")
    (root / "worlds").mkdir()
    shutil.copy(DATA / "worlds" / "room.world", root / "worlds")
    (root / "cell" / "clients").mkdir(parents=True)
    (root / "cell" / "clients" / "go.py").write_text("print('hello')\n")
    scenario = root / "cell" / "cell.yaml"
    doc = {
        "robots": [
            {
                "robot": "package://ur_description/urdf/ur_mocked.urdf.xacro",
                "robot_args": {"ur_type": "ur3e", "name": "ur"},
            }
        ],
        "environment": {"map": "../worlds/room.world"},
        "client": {
            "command": [
                sys.executable,
                "clients/go.py",
                str(root / "worlds" / "room.world"),
                "/cell",
            ]
        },
    }
    scenario.write_text(yaml.safe_dump(doc))
    return scenario


def test_the_materialised_bundle_builds_the_same_world_once_the_clients_files_are_gone(
    tmp_path, monkeypatch
):
    client = tmp_path / "client"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(client / "ws"))
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(client / "models"))
    scenario = _cell(client)
    (spec,) = iteration_specs(load_run_file(scenario), tmp_path / "out", 1)
    reference = build_world(spec.scenario, tmp_path / "ref")

    bundle, blobs = collect_bundle(spec)
    paths = {Path(f.path) for f in bundle.files}
    ur = client / "ws" / "ur_description"
    assert {
        scenario,
        ur / "package.xml",
        ur / "urdf" / "ur_mocked.urdf.xacro",
        ur / "config" / "ur3e" / "joint_limits.yaml",
        client / "worlds" / "room.world",
        client / "cell" / "clients" / "go.py",
    } <= paths
    assert any(p.is_relative_to(client / "models" / "crate") for p in paths)
    assert any(p.suffix == ".stl" and "ur3e" in p.parts for p in paths)
    assert not any("ur10e" in p.parts for p in paths)  # what is read, not whole folders
    assert all(not p.is_relative_to(Path(sys.prefix)) for p in paths)
    assert {hashlib.sha256(b).hexdigest() for b in blobs.values()} == set(blobs)
    assert bundle.size == sum(f.size for f in bundle.files)

    store = BlobStore(tmp_path / "worker" / "blobs")
    assert store.missing(f.sha256 for f in bundle.files) == list(
        dict.fromkeys(f.sha256 for f in bundle.files)
    )
    for digest, data in blobs.items():
        store.put(digest, data)
    assert store.missing(f.sha256 for f in bundle.files) == []
    tree = materialise(bundle, store, tmp_path / "worker" / "trees")
    assert materialise(bundle, store, tmp_path / "worker" / "trees") == tree  # built once
    client.rename(tmp_path / "gone")  # the worker's machine has none of the client's files

    local = localise_spec(spec, bundle, tree, tmp_path / "worker" / "run")
    robot = local.scenario.robots[0].robot
    assert robot == mirror(ur / "urdf" / "ur_mocked.urdf.xacro", tree)
    assert local.scenario.environment.map == mirror(client / "worlds" / "room.world", tree)
    assert local.scenario.source == mirror(scenario, tree)
    assert local.client is not None
    assert local.client.cwd == mirror(client / "cell", tree)
    # the client's interpreter becomes the worker's; an absolute argument is mirrored
    # (a topic-like argument stays as it is)
    world = str(mirror(client / "worlds" / "room.world", tree))
    command = ("python", "clients/go.py", world, "/cell")
    assert local.client.command == command
    assert local.out_dir == tmp_path / "worker" / "run"
    assert local.recording_path == local.out_dir / "recording.mcap"
    env = bundle_env(bundle, tree)
    assert env["ROS_PACKAGE_PATH"] == str(mirror(client / "ws", tree))
    for var, value in env.items():
        if value is None:
            monkeypatch.delenv(var, raising=False)
        else:
            monkeypatch.setenv(var, value)
    remote = build_world(local.scenario, tmp_path / "worker" / "run")
    assert remote.sha256 == reference.sha256  # the compiled model does not know where it lives


def test_a_blob_whose_bytes_do_not_match_its_name_is_refused(tmp_path):
    store = BlobStore(tmp_path)
    with pytest.raises(RunnerError, match=r"received bytes hash to"):
        store.put(hashlib.sha256(b"right").hexdigest(), b"wrong")
    assert list(tmp_path.iterdir()) == []


def test_paths_are_rewritten_through_frozen_dataclasses_and_the_rest_is_kept(tmp_path):
    scenario = tmp_path / "s.yaml"
    doc = {
        "robots": [{"robot": "demo"}],
        "duration": 0.1,
        "logging": {"destination": [{"type": "JsonLines", "path": "logs/events.jsonl"}]},
    }
    scenario.write_text(yaml.safe_dump(doc))
    (spec,) = iteration_specs(load_run_file(scenario), tmp_path / "out", 1)
    moved = rewrite_paths(spec, lambda p: Path("/elsewhere", *p.parts[1:]))
    assert moved.scenario.source == Path("/elsewhere", *scenario.parts[1:])
    assert moved.out_dir == Path("/elsewhere", *spec.out_dir.parts[1:])
    assert moved.scenario.robots == spec.scenario.robots  # "demo" is a name, not a path
    assert moved.scenario.criteria is spec.scenario.criteria  # untouched parts stay as they are
    assert (
        dataclasses.replace(
            moved, out_dir=spec.out_dir, recording_path=spec.recording_path, scenario=spec.scenario
        )
        == spec
    )
    # A file sink writes into the worker's iteration folder (and so comes back with it).
    (sink,) = spec.scenario.logging.destinations
    assert dict(sink.options)["path"] == str(tmp_path / "logs" / "events.jsonl")
    bundle, _ = collect_bundle(spec)
    local = localise_spec(spec, bundle, tmp_path / "tree", tmp_path / "run")
    (sink,) = local.scenario.logging.destinations
    assert dict(sink.options)["path"] == str(tmp_path / "run" / "sinks" / "events.jsonl")
