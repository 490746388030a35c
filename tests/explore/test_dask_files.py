"""``harness explore --backend dask`` on a worker that cannot see the client's files: the
scenario, its robot (a URDF in a ROS package with meshes), its world (MJCF with a mesh and a
texture) and its client program travel as ``harness run --backend dask`` sends them.

The worker is a real ``dask worker`` process in its own mount namespace with a private tmpfs
over this pytest run's temporary root (the ``isolated_worker`` fixture of
tests/scenario/test_dask_remote.py: ``unshare --mount``, 127.0.0.1). Every example must run
(not fail on a missing file), the kept examples come back into the work folder, and the
minimal case's files are the client's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from harness import cli
from harness.explore import SearchOptions, load_plan, search
from tests.scenario.test_dask_remote import _client_files, isolated_worker  # noqa: F401

pytest.importorskip("distributed", reason="optional Dask backend not installed")


def _explored(root: Path, fail: bool) -> Path:
    """The remote scenario with an explore section over the arm's start and the seed; with
    ``fail``, collisions are judged and the arm starts inside its base for large angles."""
    scenario = _client_files(root)
    doc = yaml.safe_load(scenario.read_text())
    doc["seed"] = 0
    doc["robots"][0]["initial_joint_positions"] = {"shoulder": 0.0}
    doc["explore"] = {
        "parameters": {
            "robots.0.initial_joint_positions.shoulder": {"low": -0.3, "high": 0.3},
            "seed": {"integers": [0, 100]},
        }
    }
    if fail:
        doc["criteria"] = {"joint_limits": True}
        doc["explore"]["parameters"]["robots.0.initial_joint_positions.shoulder"] = {
            "low": 0.0,
            "high": 1.6,  # beyond the joint's 1.5 limit
        }
    scenario.write_text(yaml.safe_dump(doc, sort_keys=False))
    return scenario


@pytest.mark.slow
def test_a_worker_without_the_files_runs_every_example(tmp_path, isolated_worker):  # noqa: F811
    address, _client = isolated_worker
    scenario = _explored(tmp_path / "client", fail=False)
    options = SearchOptions(
        work=tmp_path / "work", examples=4, keep_passing=2, seed=3, scheduler=address
    )
    result = search(load_plan(scenario), options)
    assert len(result.examples) == 4
    reasons = [e.reason for e in result.examples if not e.passed]
    assert reasons == []  # a missing file would fail every example ("error: ...")
    kept = [Path(e.kept) for e in result.examples if e.kept]
    assert len(kept) == 2
    for folder in kept:  # back on the client, under the work folder
        assert folder.is_relative_to(tmp_path / "work")
        assert (folder / "recording.mcap").stat().st_size > 0
        assert "remote_arm" in (folder / "scenario.yaml").read_text()


@pytest.mark.slow
def test_explore_cli_on_a_remote_worker_finds_and_writes_the_minimal_case(
    tmp_path,
    isolated_worker,  # noqa: F811
):
    address, _client = isolated_worker
    scenario = _explored(tmp_path / "client", fail=True)
    out = tmp_path / "out"
    code = cli.main(
        ["explore", str(scenario), "--examples", "20", "--backend", "dask",
         "--scheduler", address, "--out", str(out)]
    )  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert code == 1, summary
    assert summary["minimal"]["fails_under_harness_run"] is True
    assert summary["minimal"]["replay"] == "REPRODUCED"
    # the minimal scenario names the client's files, not the worker's tree
    text = (out / "minimal.yaml").read_text()
    assert str(tmp_path / "client" / "ws") in text
    assert "trees" not in text
