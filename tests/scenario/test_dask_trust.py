"""A Dask worker trusts nothing it finds on its own disk (issue 31, break 2).

Another local user can take the predictable cache folder ``<temp>/harness-worker-<uid>`` first,
or plant a file under the sha256 of a file the victim's run sends. The worker must refuse a
cache folder that is not private to its user, and hash every blob and tree before using it:
a planted blob or tree is replaced by the real bytes, and the iteration runs the real robot.

The cluster is a real in-process ``LocalCluster`` on 127.0.0.1 (its worker threads share this
process's environment, so ``HARNESS_WORKER_DIR`` reaches them); the "other user" is uid 65534
(nobody), which the test, running as root, gives the planted files and folders.
"""

import hashlib
import os
import tempfile
from pathlib import Path

import pytest
import yaml

from harness.recording import Recording
from harness.scenario import DaskBackend, iteration_specs, load_run_file
from harness.scenario.bundle import BlobStore, collect_bundle, materialise, mirror
from harness.scenario.dask_backend import worker_dir
from harness.scenario.errors import RunnerError
from harness.scenario.runner import session_iteration_runner

distributed = pytest.importorskip("distributed", reason="optional Dask backend not installed")

NOBODY = 65534
URDF = """<?xml version="1.0"?>
<robot name="{name}_arm">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0 0 0.15"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="{name}_joint" type="revolute"><origin xyz="0 0 0.3"/>
    <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" velocity="5" effort="50"/></joint>
</robot>
"""
REAL = URDF.format(name="real")
PLANTED = URDF.format(name="planted")

needs_root = pytest.mark.skipif(os.geteuid() != 0, reason="giving files to another uid needs root")


def _spec(root: Path):
    """One iteration of a scenario whose robot is a URDF of the client's (so it is a blob)."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "arm.urdf").write_text(REAL)
    (root / "arm.yaml").write_text(
        yaml.safe_dump({"robots": [{"robot": "arm.urdf"}], "duration": 0.05})
    )
    (spec,) = iteration_specs(load_run_file(root / "arm.yaml"), root / "out", 1)
    return spec


def _run(spec):
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp://",
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        backend = DaskBackend(cluster.scheduler_address)
        (result,) = backend.run(session_iteration_runner(), [spec], lambda r: None)
    return result, backend.transfers


def _compiled_model(recording: Path) -> str:
    with Recording(recording) as rec:
        return rec.attachment("model.mjcf.xml").decode()


def _give_away(path: Path) -> None:
    os.chown(path, NOBODY, NOBODY)


@needs_root
def test_a_blob_planted_under_the_victims_hash_is_detected_and_fetched_again(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HARNESS_WORKER_DIR", str(cache))
    spec = _spec(tmp_path / "client")
    digest = hashlib.sha256(REAL.encode()).hexdigest()
    # The cache is the worker's own and private; the planted blob in it is another user's.
    (cache / "blobs").mkdir(parents=True)
    cache.chmod(0o700)
    planted = cache / "blobs" / digest
    planted.write_text(PLANTED)
    _give_away(planted)

    result, transfers = _run(spec)

    assert result.error is None, result.error
    assert result.passed, result.reason
    model = _compiled_model(result.recording)
    assert "real_joint" in model
    assert "planted" not in model
    assert planted.read_text() == REAL  # replaced by the bytes the client sent
    ((_, (fetched, _)),) = transfers.fetched.items()
    assert fetched == transfers.sent_files  # the planted blob counted as missing


@needs_root
def test_a_tree_planted_under_the_bundles_digest_is_rebuilt(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HARNESS_WORKER_DIR", str(cache))
    spec = _spec(tmp_path / "client")
    bundle, blobs = collect_bundle(spec)
    # A complete tree for this bundle, its robot file swapped for the planted one.
    store = BlobStore(tmp_path / "elsewhere")
    for digest, data in blobs.items():
        store.put(digest, data)
    worker_dir()
    tree = materialise(bundle, store, cache / "trees")
    robot = mirror(tmp_path / "client" / "arm.urdf", tree)
    robot.unlink()
    robot.write_text(PLANTED)
    _give_away(robot)
    # The blobs are all there and true: only the tree lies.
    for digest, data in blobs.items():
        BlobStore(cache / "blobs").put(digest, data)

    result, transfers = _run(spec)

    assert result.error is None, result.error
    assert result.passed, result.reason
    model = _compiled_model(result.recording)
    assert "real_joint" in model
    assert "planted" not in model
    assert robot.read_text() == REAL
    ((_, (fetched, _)),) = transfers.fetched.items()
    assert fetched == 0


@needs_root
def test_a_cache_folder_of_another_user_is_refused_and_nothing_in_it_is_used(tmp_path, monkeypatch):
    # The predictable default name, taken first by another user with a planted blob inside.
    monkeypatch.delenv("HARNESS_WORKER_DIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    cache = tmp_path / f"harness-worker-{os.getuid()}"
    (cache / "blobs").mkdir(parents=True)
    cache.chmod(0o700)
    planted = cache / "blobs" / hashlib.sha256(REAL.encode()).hexdigest()
    planted.write_text(PLANTED)
    for path in (planted, cache / "blobs", cache):
        _give_away(path)
    spec = _spec(tmp_path / "client")

    result, _ = _run(spec)

    assert not result.passed
    assert result.error is not None
    line = f"worker cache {cache} is owned by uid {NOBODY}, not by this worker's user (uid 0)"
    assert line in result.error
    assert "\n" not in result.error
    assert not spec.recording_path.exists()  # nothing ran
    assert sorted(p.name for p in cache.rglob("*")) == sorted(["blobs", planted.name])


def test_a_cache_folder_others_may_write_or_a_link_is_refused_with_one_line(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("HARNESS_WORKER_DIR", str(cache))
    cache.mkdir()
    cache.chmod(0o777)
    with pytest.raises(RunnerError) as refused:
        worker_dir()
    assert str(refused.value).startswith(f"worker cache {cache} has mode 0777, group or others ")
    assert "\n" not in str(refused.value)
    cache.chmod(0o750)
    with pytest.raises(RunnerError, match=r"has mode 0750"):
        worker_dir()

    target = tmp_path / "target"
    target.mkdir(mode=0o700)
    link = tmp_path / "link"
    link.symlink_to(target)
    monkeypatch.setenv("HARNESS_WORKER_DIR", str(link))
    with pytest.raises(RunnerError, match=rf"^worker cache {link} is not a folder"):
        worker_dir()


def test_a_missing_cache_folder_is_created_private_whatever_the_umask(tmp_path, monkeypatch):
    monkeypatch.delenv("HARNESS_WORKER_DIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    old = os.umask(0)
    try:
        folder = worker_dir()
    finally:
        os.umask(old)
    assert folder == tmp_path / f"harness-worker-{os.getuid()}"
    info = folder.lstat()
    assert info.st_mode & 0o777 == 0o700
    assert info.st_uid == os.geteuid()
    assert worker_dir() == folder  # reused once it is private


def test_a_recording_returned_into_a_path_another_writer_holds_is_refused(tmp_path, monkeypatch):
    # Two runs sharing --out (break 3): the returned recording does not overwrite a recording
    # another writer holds at that path; the iteration fails naming it and the holder.
    from harness.recording import Recorder

    monkeypatch.setenv("HARNESS_WORKER_DIR", str(tmp_path / "cache"))
    spec = _spec(tmp_path / "client")
    spec.recording_path.parent.mkdir(parents=True)
    metadata = {
        "timestep": "0.002",
        "integrator": "IMPLICITFAST",
        "seed": "0",
        "model_sha256": "0" * 64,
        "control_modes": "{}",
    }
    with Recorder(spec.recording_path, metadata=metadata) as holder:
        before = spec.recording_path.read_bytes()
        result, _ = _run(spec)
        assert spec.recording_path.read_bytes() == before
        holder.flush()
    assert result.error is not None
    assert f"{spec.recording_path}: another session is recording to this file" in result.error
    assert f"(pid {os.getpid()}, this process)" in result.error
    with Recording(spec.recording_path, strict=True) as rec:
        assert rec.complete
        assert rec.metadata["model_sha256"] == "0" * 64  # the holder's file, whole
