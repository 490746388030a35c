"""Maximum sizes: a bridge frame over the server's ``max_size`` closes that connection only
(close code 1009, the others carry on); fragmented messages are bounded; a recording stops at
its ``max_bytes`` with a clear error and is still a valid file; scenario and runner files have
a size limit, also after YAML alias expansion, and a nesting limit. (Model XML file limits:
test_files.py.)"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import numpy as np
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from harness.recording import PhysicsState, Recorder, Recording
from harness.recording.errors import RecordingWriteError
from harness.rosbridge import Bridge, BridgeServer
from harness.scenario import Scenario, ScenarioError, load_run_file
from harness.scenario._validation import MAX_DOCUMENT_BYTES

METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def test_default_frame_limit_is_16_mib() -> None:
    assert BridgeServer().max_size == 16 * 2**20


def test_oversized_frame_closes_only_its_connection() -> None:
    async def main() -> None:
        async with BridgeServer(max_size=64 * 1024, ping_interval=None) as server:
            other = await connect(server.url, compression=None)
            await other.send(
                json.dumps({"op": "subscribe", "topic": "/t", "type": "std_msgs/msg/String"})
            )
            big = await connect(server.url, compression=None, max_size=None)
            await big.send(
                json.dumps({"op": "advertise", "topic": "/t", "type": "std_msgs/msg/String"})
            )
            frame = {"op": "publish", "topic": "/t", "msg": {"data": "x" * 100_000}}
            await big.send(json.dumps(frame))
            with pytest.raises(ConnectionClosed) as info:
                await asyncio.wait_for(big.recv(), 10)
            assert info.value.rcvd is not None
            assert info.value.rcvd.code == 1009  # message too big
            # the subscriber got nothing of it and still works
            await other.send(
                json.dumps({"op": "call_service", "service": "/rosapi/topics", "id": "x"})
            )
            answer = json.loads(await asyncio.wait_for(other.recv(), 10))
            assert answer["op"] == "service_response"
            await other.close()

    asyncio.run(main())


def test_fragmented_messages_are_bounded() -> None:
    bridge = Bridge(max_fragment_bytes=1000)
    c = bridge.connect()
    out = []
    for num in range(3):
        frame = {"op": "fragment", "id": "f", "data": "x" * 400, "num": num, "total": 5}
        out += bridge.receive(c, json.dumps(frame), 0)
    statuses = [json.loads(o.data) for o in out if o.op == "status"]
    assert len(statuses) == 1
    assert "exceed 1000 bytes" in statuses[0]["msg"]


def test_recording_stops_at_its_size_limit(tmp_path: Path) -> None:
    path = tmp_path / "capped.mcap"
    state = np.random.default_rng(0).random(2000)  # incompressible: the file grows fast
    rec = Recorder(path, metadata=METADATA, max_bytes=200_000, chunk_size=32 * 1024)
    written = 0
    error: RecordingWriteError | None = None
    for k in range(10_000):
        try:
            rec.write_physics_state(
                PhysicsState(
                    step=k, sim_time_ns=k, state_spec=1, state=state, qpos=state[:7], qvel=state[:6]
                )
            )
            written += 1
            if k % 10 == 0:
                rec.flush()
        except RecordingWriteError as exc:
            error = exc
            break
    assert error is not None
    assert "MiB limit (max_bytes)" in str(error)
    assert 0 < written < 10_000
    with pytest.raises(RecordingWriteError, match="limit"):
        rec.write_physics_state(PhysicsState(
            step=10**6, sim_time_ns=10**6, state_spec=1, state=state, qpos=state[:7],
            qvel=state[:6],
        ))  # fmt: skip
    with pytest.raises(RecordingWriteError, match="limit"):
        rec.close()  # reports why, after finishing the file
    assert path.stat().st_size < 200_000 + 32 * 1024 * 12
    with Recording(path, strict=True) as done:
        assert done.complete
        assert 0 < len(list(done.physics_states())) <= written


def test_bad_recording_limit_is_refused(tmp_path: Path) -> None:
    with pytest.raises(RecordingWriteError, match="max_bytes"):
        Recorder(tmp_path / "x.mcap", metadata=METADATA, max_bytes=0)


def _alias_bomb(levels: int) -> str:
    lines = ["x0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"]
    for i in range(1, levels):
        lines.append(f"x{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name", ["scenario.yaml", "runner.json"])
def test_oversized_scenario_files_are_refused(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    with path.open("wb") as f:  # sparse
        f.truncate(MAX_DOCUMENT_BYTES + 1)
    load = Scenario.load if name.startswith("scenario") else load_run_file
    with pytest.raises(ScenarioError, match="MiB limit for scenario and runner files") as info:
        load(path)
    assert str(path) in str(info.value)


def test_yaml_alias_bomb_is_refused_quickly(tmp_path: Path) -> None:
    """Nine levels of ten aliases: 10**9 values once expanded, ~300 bytes of YAML."""
    path = tmp_path / "bomb.yaml"
    path.write_text(_alias_bomb(9).replace("x8:", "robots:"))
    with pytest.raises(ScenarioError, match="YAML aliases"):
        Scenario.load(path)
    small = tmp_path / "anchors.yaml"  # ordinary anchors stay allowed
    small.write_text("robots:\n  - &r {robot: demo}\n")
    assert Scenario.load(small).robots


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
@pytest.mark.slow
def test_deeply_nested_scenario_is_refused(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"deep{suffix}"
    path.write_text('{"robots": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(ScenarioError, match="nested too deeply"):
        Scenario.load(path)
