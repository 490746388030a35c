"""Byte-reproducible recordings: chunk boundaries depend on the records, not on the wall clock.

Two identical session runs give files with the same SHA-256; wall-clock flushes
(:meth:`Recorder.checkpoint`, what the flush thread does) change nothing in the finished file,
yet every message recorded before a checkpoint is on disk and reads back from a copy taken
then (what a kill -9 leaves)."""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np

from harness.recording import PhysicsState, Recorder, Recording, describe_run
from harness.session import Session
from harness.sim import Simulation


def _session_run(path: Path) -> str:
    with Session("demo", record_to=path, joint_states_hz=50) as session:
        session.command("joint1", position=0.4)
        session.step(120)
        session.set_positions({"joint2": 0.2})
        session.step(80)
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_two_identical_session_runs_give_identical_files(tmp_path: Path) -> None:
    first = _session_run(tmp_path / "a.mcap")
    second = _session_run(tmp_path / "b.mcap")
    assert first == second
    with Recording(tmp_path / "a.mcap") as rec:
        assert rec.complete
        assert rec.last_step == 200


def _recorder_run(path: Path, checkpoints: set[int], copies: dict[int, bytes]) -> str:
    """The demo robot, 600 steps, small chunks; ``checkpoint()`` after the given steps,
    with a copy of the file as it is on disk then."""
    from harness.models import load_robot

    robot = load_robot("demo", control="position")
    sim = Simulation(robot)
    sim.reset()
    description = describe_run(robot, seed=3)
    with Recorder(
        path,
        metadata=description.metadata,
        attachments=description.attachments,
        chunk_size=64 * 1024,
        library="harness-test",
        flush_interval_s=3600.0,  # only the explicit checkpoints below
    ) as rec:
        for k in range(600):
            if k == 100:
                sim.command("joint1", position=0.5)
            if k:
                sim.step()
            rec.write_physics_state(
                PhysicsState(
                    step=sim.step_index,
                    sim_time_ns=sim.sim_time_ns,
                    state_spec=sim.state_spec,
                    state=sim.get_state(),
                    qpos=sim.data.qpos,
                    qvel=sim.data.qvel,
                )
            )
            if k in checkpoints:
                rec.checkpoint()
                copies[k] = path.read_bytes()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_checkpoints_change_no_byte_and_keep_everything_on_disk(tmp_path: Path) -> None:
    copies: dict[int, bytes] = {}
    plain = _recorder_run(tmp_path / "plain.mcap", set(), {})
    flushed = _recorder_run(tmp_path / "flushed.mcap", {50, 51, 230, 231, 450}, copies)
    assert plain == flushed
    with Recording(tmp_path / "flushed.mcap") as rec:
        assert len(rec.scan.chunks) > 4  # the checkpoints fell inside open chunks
    for k, blob in copies.items():
        cut = tmp_path / f"cut{k}.mcap"
        cut.write_bytes(blob)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rec = Recording(cut)
        with rec:
            assert not rec.complete
            assert [p.message for p in rec.problems] == [
                "truncated: the file ends before its summary"
            ]
            steps = rec.physics_state_arrays().steps
            assert np.array_equal(steps, np.arange(k + 1))  # every state up to the checkpoint


def test_time_flushes_of_a_real_run_keep_files_identical(
    tmp_path: Path, record_run: ModuleType
) -> None:
    """The flush thread at 1 ms: many provisional tails during the run, same bytes."""
    record_run.record(tmp_path / "a.mcap", 400, flush_interval_s=0.001, chunk_size=32 * 1024)
    record_run.record(tmp_path / "b.mcap", 400, flush_interval_s=1000.0, chunk_size=32 * 1024)
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()
