"""The optional token: with ``token=...`` the server refuses (HTTP 401, before any frame) every
WebSocket handshake that does not present it as ``?token=`` or ``Authorization: Bearer``;
roslibpy and roslibjs reach it through the URL alone."""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from harness.errors import ConfigError
from harness.rosbridge import BridgeServer
from harness.session import Session

TOKEN = "s3cret-token"
NODE_DIR = Path(__file__).resolve().parents[1] / "node"
NODE = shutil.which("node")


async def _topics(url: str, **kwargs: object) -> list[str]:
    async with connect(url, compression=None, **kwargs) as ws:  # type: ignore[arg-type]
        await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics", "id": "1"}))
        answer = json.loads(await asyncio.wait_for(ws.recv(), 10))
        return list(answer["values"]["topics"])


def test_token_required_and_accepted_both_ways() -> None:
    async def main() -> None:
        async with BridgeServer(token=TOKEN, ping_interval=None) as server:
            bare = f"ws://127.0.0.1:{server.port}"
            assert server.url == f"{bare}/?token={TOKEN}"
            for url in (bare, f"{bare}/?token=wrong", f"{bare}/?other={TOKEN}"):
                with pytest.raises(InvalidStatus) as info:
                    await _topics(url)
                assert info.value.response.status_code == 401
            with pytest.raises(InvalidStatus):
                await _topics(bare, additional_headers={"Authorization": "Bearer nope"})
            assert server.bridge.connections == []  # nothing got as far as the bridge
            assert isinstance(await _topics(server.url), list)
            await _topics(bare, additional_headers={"Authorization": f"Bearer {TOKEN}"})

    asyncio.run(main())


def test_no_token_by_default() -> None:
    async def main() -> None:
        async with BridgeServer(ping_interval=None) as server:
            assert "token" not in server.url
            assert isinstance(await _topics(server.url), list)

    asyncio.run(main())


def test_empty_token_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="token"):
        BridgeServer(token="")


ROSLIBPY = textwrap.dedent(
    """
    import sys
    import roslibpy
    ros = roslibpy.Ros(sys.argv[1])
    try:
        ros.run(timeout=4)
    except Exception as exc:
        print("refused", type(exc).__name__, flush=True)
        sys.exit(0)
    print("topics", len(ros.get_topics()), flush=True)
    ros.close()
    """
)


async def _in_subprocess(cmd: list[str], cwd: Path | None = None) -> str:
    async with BridgeServer(token=TOKEN, ping_interval=None) as server:
        bare = f"ws://127.0.0.1:{server.port}"
        out = []
        for url in (server.url, f"{bare}/?token=wrong"):
            proc = await asyncio.create_subprocess_exec(
                *cmd, url, cwd=cwd, stdout=asyncio.subprocess.PIPE
            )
            stdout, _ = await asyncio.wait_for(proc.communicate(), 60)
            out.append(stdout.decode().strip())
        return "\n".join(out)


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_roslibpy_presents_the_token_in_the_url() -> None:
    out = asyncio.run(_in_subprocess([sys.executable, "-c", ROSLIBPY]))
    with_token, wrong = out.splitlines()[0], out.splitlines()[-1]
    assert with_token.startswith("topics"), out
    assert wrong.startswith("refused"), out


ROSLIBJS = textwrap.dedent(
    """
    import * as ROSLIB from "roslib";
    const ros = new ROSLIB.Ros({ url: process.argv[1] });
    const timer = setTimeout(() => { console.log("timeout"); process.exit(1); }, 8000);
    ros.on("connection", () => {
      ros.getTopics((r) => {
        console.log("topics " + r.topics.length);
        clearTimeout(timer);
        ros.close();
      });
    });
    ros.on("error", () => { console.log("refused"); clearTimeout(timer); process.exit(0); });
    """
)


@pytest.mark.timeout(120)
@pytest.mark.skipif(NODE is None, reason="node is not installed")
@pytest.mark.skipif(
    not (NODE_DIR / "node_modules" / "roslib").is_dir(),
    reason="tests/node/node_modules lacks roslib (run `make node-deps`)",
)
@pytest.mark.slow
def test_roslibjs_presents_the_token_in_the_url() -> None:
    assert NODE is not None
    # --eval resolves "roslib" from the working directory: tests/node
    cmd = [NODE, "--input-type=module", "--eval", ROSLIBJS]
    out = asyncio.run(_in_subprocess(cmd, cwd=NODE_DIR))
    lines = out.splitlines()
    assert lines[0].startswith("topics"), out
    assert lines[-1] == "refused", out


def test_refusal_names_what_is_missing_without_the_token() -> None:
    """The 401 answer says what is missing and never echoes the expected token."""

    async def main() -> None:
        async with BridgeServer(token=TOKEN, ping_interval=None) as server:
            bare = f"ws://127.0.0.1:{server.port}"
            for url, reason in ((bare, "no token presented"), (f"{bare}/?token=x", "wrong token")):
                with pytest.raises(InvalidStatus) as info:
                    await _topics(url)
                body = info.value.response.body.decode()
                assert reason in body
                assert TOKEN not in body

    asyncio.run(main())


def test_session_with_a_token() -> None:
    with Session("demo", token=TOKEN) as session:
        assert session.url.endswith(f"/?token={TOKEN}")
        bare = session.url.split("/?")[0]

        async def main() -> None:
            with pytest.raises(InvalidStatus) as info:
                await _topics(bare)
            assert info.value.response.status_code == 401
            assert "/robot_description" in await _topics(session.url)

        asyncio.run(main())


def test_session_token_with_an_external_server_is_refused() -> None:
    with pytest.raises(ConfigError, match="token"):
        Session("demo", token=TOKEN, connect_to="ws://127.0.0.1:9")


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_serve_with_a_token_from_the_environment() -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--port", "0", "--clock", "lockstep"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "HARNESS_TOKEN": TOKEN},
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()
    try:
        url = first.split()[2]
        assert url.endswith(f"/?token={TOKEN}"), first

        async def main() -> None:
            with pytest.raises(InvalidStatus):
                await _topics(url.split("/?")[0])
            assert await _topics(url)

        asyncio.run(main())
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
    assert proc.returncode == 0
