"""Degraded cases of the attack pass: a server-wide cap on send queues (slow clients closed
with status 1008 and a counted reason), duplicate ``Authorization`` headers refused with 400
(no traceback), non-finite trajectory velocities and duplicate joint names refused, and a
scenario object clashing with a robot link named against the scenario file."""

from __future__ import annotations

import asyncio
import json
import logging
import math
from pathlib import Path
from typing import Any

import pytest
import yaml
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from harness.controllers.command_topics import apply_joint_state, parse_trajectory
from harness.models import load_robot
from harness.rosbridge import BridgeServer
from harness.scenario import Scenario, ScenarioError
from harness.scenario.world import plan_world
from harness.session import CommandRefused
from harness.sim import Simulation

ROOT = Path(__file__).resolve().parents[2]
TWO_LINK = ROOT / "tests" / "data" / "scenario" / "robots" / "two_link.urdf"


def test_send_queues_have_a_server_wide_cap() -> None:
    async def main() -> None:
        cap = 2 * 2**20
        async with BridgeServer(
            ping_interval=None, send_queue_bytes=64 * 2**20, max_queued_bytes=cap
        ) as server:
            bridge = server.bridge
            bridge.advertise("/big", "std_msgs/msg/String")
            sub = json.dumps({"op": "subscribe", "topic": "/big", "queue_length": 100_000})
            slow = []
            for _ in range(3):  # subscribe, then never read
                ws = await connect(server.url, compression=None, max_queue=1, close_timeout=0.1)
                await ws.send(sub)
                slow.append(ws)
            reader = await connect(server.url, compression=None)
            await reader.send(json.dumps({"op": "call_service", "service": "/rosapi/topics"}))
            await asyncio.wait_for(reader.recv(), 10)  # every subscription is in
            data = "x" * 64 * 1024
            peak = 0
            for _ in range(400):  # 25 MiB per slow client
                bridge.publish("/big", "std_msgs/msg/String", {"data": data}, 0)
                server.flush()
                peak = max(peak, server.queued_bytes)
                await asyncio.sleep(0)
            reason = "send queues over the server-wide limit"
            assert server.closed.get(reason, 0) >= 1, server.closed
            assert peak <= cap + 2 * len(data)
            closed = 0
            for ws in slow:
                try:
                    while True:
                        await asyncio.wait_for(ws.recv(), 10)
                except ConnectionClosed as exc:
                    closed += exc.rcvd is not None and exc.rcvd.code == 1008
            assert closed >= 1
            # the server still answers everyone else
            await reader.send(json.dumps({"op": "call_service", "service": "/rosapi/topics"}))
            while True:
                frame = json.loads(await asyncio.wait_for(reader.recv(), 10))
                if frame["op"] == "service_response":
                    break
            await reader.close()

    asyncio.run(main())


def test_duplicate_authorization_headers_get_400_without_a_traceback(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async def main() -> str:
        async with BridgeServer(token="tok", ping_interval=None) as server:
            reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
            writer.write(
                b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                b"Sec-WebSocket-Version: 13\r\nAuthorization: Bearer tok\r\n"
                b"Authorization: Bearer other\r\n\r\n"
            )
            await writer.drain()
            status = await asyncio.wait_for(reader.readline(), 10)
            writer.close()
            return status.decode()

    with caplog.at_level(logging.ERROR):
        status = asyncio.run(main())
    assert status.startswith("HTTP/1.1 400"), status
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]


def _trajectory(**point: Any) -> dict[str, Any]:
    return {
        "header": {"stamp": {"sec": 0, "nanosec": 0}},
        "joint_names": ["joint1", "joint2"],
        "points": [{"positions": [0.1, 0.2], "time_from_start": {"sec": 1, "nanosec": 0}, **point}],
    }


def test_non_finite_trajectory_values_and_duplicate_names_are_refused() -> None:
    sim = Simulation(load_robot("demo", control="position"))
    with pytest.raises(CommandRefused, match="point 0: velocities of joint 'joint2' is nan"):
        parse_trajectory(sim, _trajectory(velocities=[0.0, math.nan]), 0)
    with pytest.raises(CommandRefused, match="point 0: accelerations of joint 'joint1' is inf"):
        parse_trajectory(sim, _trajectory(accelerations=[math.inf, 0.0]), 0)
    parse_trajectory(sim, _trajectory(velocities=[0.0, 0.0]), 0)  # finite: accepted
    twice = {**_trajectory(), "joint_names": ["joint1", "joint1"]}
    with pytest.raises(CommandRefused, match="trajectory names joint 'joint1' twice"):
        parse_trajectory(sim, twice, 0)
    many = ["joint1"] * 600_000
    message = {"name": many, "position": [0.1] * len(many), "velocity": [], "effort": []}
    with pytest.raises(CommandRefused, match="joint state command names joint 'joint1' twice"):
        apply_joint_state(sim, message)


def test_object_clashing_with_a_robot_link_names_the_scenario_file(tmp_path: Path) -> None:
    path = tmp_path / "clash.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "robots": [{"robot": str(TWO_LINK)}],
                "environment": {"map": "empty"},
                "clock": {"mode": "lockstep"},
                "objects": [
                    {"name": "arm", "shape": "box", "size": [0.1, 0.1, 0.1], "position": [1, 0, 0]}
                ],
            }
        )
    )
    with pytest.raises(ScenarioError) as info:
        plan_world(Scenario.load(path), tmp_path / "out")
    message = str(info.value)
    assert f"{path}: objects[0].name: 'arm' is already a link or joint name" in message
    assert "choose another name" in message
