"""play: a real websockets client receives the recorded frames in order, on the sim-time
schedule (checked against the step service, never against wall-clock sleeps)."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from harness.recording import Recording
from harness.replay.play import Player


def _recorded_stamps(path: Path) -> list[tuple[int, int]]:
    with Recording(path) as rec:
        return [
            (f.step, json.loads(f.text)["msg"]["header"]["stamp"]["nanosec"])
            for f in rec.bridge_frames()
            if f.direction == 1 and f.topic == "/joint_states"
        ]


async def _stepped(path: Path) -> list[tuple[int, list[int]]]:
    player = Player(path, start="paused")
    url = await player.start()
    runner = asyncio.create_task(player.run())
    out: list[tuple[int, list[int]]] = []
    try:
        async with connect(url) as ws:
            await ws.send(json.dumps({"op": "subscribe", "topic": "/joint_states"}))
            for n in range(4):
                await ws.send(json.dumps({"op": "call_service", "service": "/harness/step",
                                          "args": {"steps": 25}, "id": f"s{n}"}))  # fmt: skip
                stamps: list[int] = []
                while True:
                    frame: dict[str, Any] = json.loads(await ws.recv())
                    if frame["op"] == "publish":
                        stamps.append(frame["msg"]["header"]["stamp"]["nanosec"])
                    elif frame["op"] == "service_response":
                        assert frame["id"] == f"s{n}"
                        assert frame["result"] is True
                        sim = frame["values"]["sim_time"]
                        out.append((sim["sec"] * 10**9 + sim["nanosec"], stamps))
                        break
    finally:
        runner.cancel()
        await player.stop()
    return out


def test_step_service_releases_exactly_the_recorded_frames_up_to_the_step(
    base_recording: Path,
) -> None:
    recorded = _recorded_stamps(base_recording)
    rounds = asyncio.run(_stepped(base_recording))
    dt = recorded[0][1] // recorded[0][0]  # the first frame is at step 10
    for n, (sim_time, stamps) in enumerate(rounds):
        assert sim_time == 25 * (n + 1) * dt
        expected = [s for step, s in recorded if 25 * n < step <= 25 * (n + 1)]
        assert stamps == expected
        assert stamps


async def _free_running(path: Path, rate: float) -> tuple[list[int], bool]:
    player = Player(path, rate=rate, start="paused")
    url = await player.start()
    runner = asyncio.create_task(player.run())
    stamps: list[int] = []
    try:
        async with connect(url) as ws:
            await ws.send(json.dumps({"op": "subscribe", "topic": "/joint_states"}))
            await ws.send(json.dumps({"op": "call_service", "service": "/harness/resume",
                                      "id": "go"}))  # fmt: skip
            await asyncio.wait_for(player.finished.wait(), timeout=30)
            await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics",
                                      "id": "fence"}))  # fmt: skip
            while True:
                frame = json.loads(await ws.recv())
                if frame["op"] == "publish":
                    stamps.append(frame["msg"]["header"]["stamp"]["nanosec"])
                elif frame.get("id") == "fence":
                    break
    finally:
        await runner
        await player.stop()
    return stamps, player.finished.is_set()


def test_free_running_playback_delivers_every_frame_in_order(base_recording: Path) -> None:
    recorded = [s for _, s in _recorded_stamps(base_recording)]
    stamps, finished = asyncio.run(_free_running(base_recording, rate=50.0))
    assert finished
    assert stamps == recorded


def test_playback_with_a_token_refuses_clients_without_it(base_recording: Path) -> None:
    async def main() -> None:
        player = Player(base_recording, start="paused", token="play-token")
        url = await player.start()
        try:
            assert url.endswith("/?token=play-token")
            with pytest.raises(InvalidStatus) as info:
                async with connect(url.split("?")[0]):
                    pass
            assert info.value.response.status_code == 401
            async with connect(url) as ws:
                await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics",
                                          "id": "t"}))  # fmt: skip
                answer = json.loads(await asyncio.wait_for(ws.recv(), 10))
                assert "/joint_states" in answer["values"]["topics"]
        finally:
            await player.stop()

    asyncio.run(main())
