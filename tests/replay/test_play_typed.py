"""``harness play`` plays every typed channel like ``ros2 bag play``: /clock, /tf and
/robot_description although no recorded client subscribed to them, latched topics to late
subscribers (the QoS the recording offers), and the clock holds until a client listens."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability

from harness.replay.play import Player
from harness.session import Session


@pytest.fixture(scope="module")
def session_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("play") / "session.mcap"
    with Session("demo", record_to=path, joint_states_hz=50) as session:
        session.step(100)  # no client: nothing went out on the bridge
    return path


def test_channels_offer_qos_as_rosbag2_writes_it(session_recording: Path) -> None:
    with AnyReader([session_recording]) as reader:
        durability = {
            c.topic: {q.durability for q in c.ext.offered_qos_profiles}  # type: ignore[union-attr]
            for c in reader.connections
        }
    assert durability["/robot_description"] == {QosDurability.TRANSIENT_LOCAL}
    assert durability["/joint_states"] == {QosDurability.VOLATILE}
    assert durability["/clock"] == {QosDurability.VOLATILE}


async def _listen(ws: Any, until: str) -> list[dict[str, Any]]:
    """Frames until the service response ``until``."""
    frames = []
    while True:
        frame = json.loads(await asyncio.wait_for(ws.recv(), 10))
        if frame.get("id") == until:
            return frames
        frames.append(frame)


async def _play(
    path: Path, start: str, topics: tuple[str, ...]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], bool]:
    """Subscribe ``topics`` on one client, play to the end (resuming a paused player), then
    subscribe ``/robot_description`` on a second client."""
    from websockets.asyncio.client import connect

    player = Player(path, rate=1000.0, start=start)  # type: ignore[arg-type]
    url = await player.start()
    runner = asyncio.create_task(player.run())
    try:
        async with connect(url) as ws:
            await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics",
                                      "id": "t"}))  # fmt: skip
            await _listen(ws, "t")
            held = player.step == player.first_step and not player.finished.is_set()
            for topic in topics:
                await ws.send(json.dumps({"op": "subscribe", "topic": topic}))
            if start == "paused":
                await ws.send(json.dumps({"op": "call_service", "service": "/harness/resume",
                                          "id": "go"}))  # fmt: skip
            await asyncio.wait_for(player.finished.wait(), 30)
            await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics",
                                      "id": "fence"}))  # fmt: skip
            early = await _listen(ws, "fence")
        async with connect(url) as late:  # after the end of the recording
            await late.send(json.dumps({"op": "subscribe", "topic": "/robot_description"}))
            await late.send(json.dumps({"op": "call_service", "service": "/rosapi/topics",
                                        "id": "fence"}))  # fmt: skip
            latecomer = await _listen(late, "fence")
    finally:
        await runner
        await player.stop()
    return early, latecomer, held


def _counts(frames: list[dict[str, Any]]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for frame in frames:
        if frame["op"] == "publish":
            counts[frame["topic"]] = counts.get(frame["topic"], 0) + 1
    return counts


def test_the_clock_holds_until_a_client_subscribes(session_recording: Path) -> None:
    early, _, held = asyncio.run(_play(session_recording, "on_client", ("/joint_states",)))
    assert held  # a client connected but listened to nothing yet
    assert _counts(early) == {"/joint_states": 11}  # every recorded one
    stamps = [f["msg"]["header"]["stamp"]["nanosec"] for f in early if f["op"] == "publish"]
    assert stamps[0] == 0  # step 0 reached the client


def test_every_typed_channel_plays_and_latched_topics_reach_late_subscribers(
    session_recording: Path,
) -> None:
    early, latecomer, _ = asyncio.run(_play(session_recording, "paused", ("/clock", "/tf")))
    assert _counts(early) == {"/clock": 11, "/tf": 11}  # no recorded client asked for them
    (description,) = [f for f in latecomer if f["op"] == "publish"]
    assert description["topic"] == "/robot_description"
    assert description["msg"]["data"].lstrip().startswith("<")
