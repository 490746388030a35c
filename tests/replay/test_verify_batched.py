"""verify's batched replay: bit-identical to stepping with harness.sim.inputs.advance, and
divergences found where they are when states are read block by block and stepped in
segments (input changes, segment limit, block ends)."""

from __future__ import annotations

import importlib
import struct
import zlib
from pathlib import Path
from types import ModuleType
from typing import Any

import mujoco
import numpy as np
import pytest

from harness.recording import Recording
from harness.replay import verify
from harness.replay.errors import RecordedDataError
from harness.sim import Simulation
from harness.sim.inputs import AppliedInput, advance, write_input

verify_module = importlib.import_module("harness.replay.verify")
SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)


def _serial(model: mujoco.MjModel, data: mujoco.MjData, inp: AppliedInput, n: int) -> np.ndarray:
    out = np.empty((n, mujoco.mj_stateSize(model, SPEC)))
    for row in out:
        advance(model, data, inp)
        mujoco.mj_getState(model, data, row, SPEC)
    return out


def _input_of(sim: Simulation, targets: dict[str, float]) -> AppliedInput:
    sim.set_positions(targets)
    sim.step()
    inp = sim.last_input
    assert inp is not None
    return inp


@pytest.mark.parametrize("control", ["position", "kinematic"])
def test_segments_are_bit_identical_to_advance(helper: ModuleType, control: str) -> None:
    """A dynamic segment runs as one Batch.rollout, a kinematic one with the writes before
    and after each step; both hand the state on exactly (two segments in a row)."""
    robot = helper.demo_robot(control)
    sim = Simulation(robot)
    sim.reset()
    model = robot.model
    first = _input_of(sim, {"joint1": 0.5, "joint2": -0.4, "joint4": -1.5})
    second = _input_of(sim, {"joint1": -0.2, "joint6": 2.0})
    assert bool(first.qpos_index.size) == (control == "kinematic")
    start = sim.get_state()

    serial = mujoco.MjData(model)
    mujoco.mj_setState(model, serial, start, SPEC)
    expected = np.concatenate(
        [_serial(model, serial, first, 150), _serial(model, serial, second, 90)]
    )

    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, start, SPEC)
    actual = np.empty_like(expected)
    batch = verify_module._Batch(model, SPEC)
    for inp, rows in ((first, actual[:150]), (second, actual[150:])):
        write_input(model, data, inp)
        if inp.qpos_index.size:
            verify_module._step_kinematic(model, data, inp, rows, SPEC)
        else:
            batch.rollout(data, rows)
    assert actual.view(np.uint64).tolist() == expected.view(np.uint64).tolist()
    assert np.array_equal(data.qpos, serial.qpos)
    # The states move: the comparison is not of a robot at rest.
    assert np.abs(expected[-1] - expected[0]).max() > 1e-3


@pytest.fixture(scope="module")
def long_run(helper: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """400 steps, three commands, in many small chunks."""
    path = tmp_path_factory.mktemp("long") / "long.mcap"
    commands = {0: helper.REACH, 130: helper.BACK, 260: {"joint1": 0.1, "joint7": 1.0}}
    return helper.record(path, commands, 400, chunk_size=16 * 1024)  # type: ignore[no-any-return]


def test_small_segments_and_blocks_reproduce(
    long_run: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    reference = verify(long_run)
    assert reference.reproduced, reference.format()
    monkeypatch.setattr(verify_module, "_SEGMENT", 7)
    monkeypatch.setattr(verify_module, "_BLOCK_ROWS", 1)
    seen: list[tuple[int, int]] = []
    report = verify(long_run, progress=lambda done, total: seen.append((done, total)))
    assert report.reproduced, report.format()
    assert (report.states_compared, report.steps_replayed) == (400, 400)
    assert (report.first_step, report.last_step, report.last_matching_step) == (0, 400, 400)
    assert len(seen) > 400 // 7
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert seen[-1] == (400, 400)


def _tampered(mcap_edit: ModuleType, src: Path, dst: Path, step: int, model: Any) -> Path:
    qpos3 = int(model.jnt_qposadr[model.joint("joint3").id])

    def edit(topic: str, msg: Any) -> Any:
        if topic == "/harness/state" and msg.step == step:
            msg.state = msg.state.copy()
            msg.state[1 + qpos3] += 1e-9
        return msg

    return mcap_edit.rewrite(src, dst, edit=edit, chunk_size=16 * 1024)  # type: ignore[no-any-return]


@pytest.mark.parametrize("where", ["block start", "block middle", "last state"])
def test_divergence_is_found_across_blocks(
    long_run: Path,
    helper: ModuleType,
    mcap_edit: ModuleType,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    where: str,
) -> None:
    model = helper.demo_robot().model
    # Block boundaries of the rewritten file (same sizes, so the same chunks as the tampered).
    same = mcap_edit.rewrite(long_run, tmp_path / "same.mcap", chunk_size=16 * 1024)
    with Recording(same) as rec:
        blocks = [b.steps for b in rec.physics_state_blocks(rows=1)]
    assert len(blocks) >= 4
    step = {
        "block start": int(blocks[2][0]),
        "block middle": int(blocks[3][len(blocks[3]) // 2]),
        "last state": 400,
    }[where]
    altered = _tampered(mcap_edit, long_run, tmp_path / "altered.mcap", step, model)
    monkeypatch.setattr(verify_module, "_BLOCK_ROWS", 1)
    monkeypatch.setattr(verify_module, "_SEGMENT", 50)
    report = verify(altered)
    assert not report.reproduced
    d = report.divergence
    assert d is not None
    assert (d.step, d.last_matching_step) == (step, step - 1)
    assert [(q.component, q.name) for q in d.quantities] == [("qpos", "joint3")]
    assert report.last_step == 400
    assert verify(same).reproduced


def test_sparse_states_are_compared_where_recorded(helper: ModuleType, tmp_path: Path) -> None:
    path = helper.record(
        tmp_path / "sparse.mcap", {0: helper.REACH, 42: helper.BACK}, 120, state_every=5
    )
    with Recording(path) as rec:
        steps = rec.physics_state_arrays().steps.tolist()
    assert steps == list(range(0, 121, 5))
    report = verify(path)
    assert report.reproduced, report.format()
    assert report.states_compared == len(steps) - 1
    assert (report.steps_replayed, report.last_step) == (120, 120)


def test_a_chunk_damaged_inside_is_refused_or_replayed_up_to_it(
    long_run: Path, tmp_path: Path
) -> None:
    """A chunk whose CRC is wrong, the data-section CRC made right: only the chunk's own
    check finds it, when the replay reads it (verify defers chunk checks to the read)."""
    blob = bytearray(long_run.read_bytes())
    with Recording(long_run) as rec:
        chunk = rec.scan.chunks[len(rec.scan.chunks) // 2]
    blob[chunk.offset + 9 + 24] ^= 0x5A  # the chunk's uncompressed_crc field
    summary_start = struct.unpack_from("<Q", blob, len(blob) - 28)[0]
    struct.pack_into("<I", blob, summary_start - 4, zlib.crc32(blob[: summary_start - 13]))
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(blob))
    with pytest.raises(
        RecordedDataError, match=rf"damaged \(chunk at byte {chunk.offset}: .*--allow-damaged"
    ):
        verify(path)
    report = verify(path, allow_damaged=True)
    assert report.reproduced, report.format()
    assert 0 < report.states_compared < 400
    assert any(f"byte {chunk.offset}" in note for note in report.notes)
