"""roslibpy 2.1 (PyPI), both transports, against the real server: pub/sub, rosapi, services
both ways, actions and reconnect. Each scenario runs in a subprocess (twisted's reactor can
only run once per process)."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import pytest

from tests.rosbridge.helpers import make_server

SCENARIO = Path(__file__).with_name("roslibpy_scenario.py")


async def _drive(transport: str) -> list[str]:
    server = make_server()
    await server.start()
    lines: list[str] = []
    try:
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            str(SCENARIO),
            str(server.port),
            transport,
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        assert proc.stdout is not None
        assert proc.stdin is not None
        try:
            async with asyncio.timeout(60):
                while line := (await proc.stdout.readline()).decode():
                    lines.append(line.rstrip())
                    if line.startswith("RECONNECT?"):
                        before = server.connection_ids()
                        assert len(before) == 1
                        server.close_connection(before[0])
                        proc.stdin.write(b"go\n")
                        await proc.stdin.drain()
                await proc.wait()
        finally:
            if proc.returncode is None:
                proc.kill()
                await proc.wait()
        assert proc.returncode == 0, "\n".join(lines)
        # the reconnect came in as a new connection with its subscriptions re-sent
        assert server.connection_ids() == [] or server.connection_ids()[0] > before[0]
    finally:
        await server.stop()
    return lines


@pytest.mark.parametrize("transport", ["twisted", "asyncio"])
@pytest.mark.slow
def test_roslibpy_scenario(transport: str) -> None:
    lines = asyncio.run(_drive(transport))
    for step in ("pubsub hello", "rosapi ok", "services ok", "actions ok", "reconnect ok", "OK"):
        assert any(line.startswith(step) for line in lines), (step, lines)
