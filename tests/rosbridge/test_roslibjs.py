"""roslibjs (npm roslib 2.1.0 under node with ws) against the real server: pub/sub, rosapi
with relative names, services both ways, actions both ways, status frames."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path

import pytest

from tests.rosbridge.helpers import make_server

NODE_DIR = Path(__file__).resolve().parents[1] / "node"
SCRIPT = NODE_DIR / "rosbridge_roslibjs.mjs"
NODE = shutil.which("node")

pytestmark = [
    pytest.mark.node,
    pytest.mark.skipif(NODE is None, reason="node is not installed"),
    pytest.mark.skipif(
        not (NODE_DIR / "node_modules" / "roslib").is_dir(),
        reason="tests/node/node_modules lacks roslib (run `make node-deps`)",
    ),
]


async def _drive() -> tuple[int, str]:
    async with make_server() as server:
        assert NODE is not None
        proc = await asyncio.create_subprocess_exec(
            NODE,
            str(SCRIPT),
            server.url,
            cwd=NODE_DIR,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        try:
            out, _ = await asyncio.wait_for(proc.communicate(), 60)
        finally:
            if proc.returncode is None:
                proc.kill()
                await proc.wait()
        assert proc.returncode is not None
        return proc.returncode, out.decode()


def test_roslibjs_scenario() -> None:
    code, out = asyncio.run(_drive())
    assert code == 0, out
    for step in (
        "pubsub ok",
        "rosapi ok",
        "call harness service ok",
        "provide service ok",
        "missing service fails ok",
        "action ok",
        "provide action ok",
        "status on bad frame ok",
    ):
        assert step in out, (step, out)
