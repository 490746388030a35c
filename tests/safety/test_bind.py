"""Servers bind the loopback interface unless a host is given explicitly; a non-loopback host
works but issues a warning (library: ExposedServerWarning; ``harness serve``: one stderr line)."""

from __future__ import annotations

import asyncio
import signal
import socket
import subprocess
import sys
import warnings

import pytest

from harness.rosbridge import BridgeServer, ExposedServerWarning, is_loopback
from harness.session import Session


def _bound_host(server: BridgeServer) -> str:
    assert server._server is not None  # the listening socket, to see what was really bound
    return str(server._server.sockets[0].getsockname()[0])


def test_bridge_server_binds_loopback_by_default() -> None:
    async def main() -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no warning for the default
            async with BridgeServer() as server:
                assert server.url.startswith("ws://127.0.0.1:")
                assert _bound_host(server) == "127.0.0.1"

    asyncio.run(main())


@pytest.mark.parametrize("host", ["127.0.0.1", "localhost", "::1"])
def test_explicit_loopback_does_not_warn(host: str) -> None:
    if host == "::1" and not socket.has_ipv6:
        pytest.skip("no IPv6")

    async def main() -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                async with BridgeServer(host=host):
                    pass
            except OSError as exc:  # ::1 not configured in this container
                pytest.skip(f"cannot bind {host}: {exc}")

    asyncio.run(main())


def test_non_loopback_host_warns_and_serves() -> None:
    async def main() -> None:
        with pytest.warns(ExposedServerWarning, match="0.0.0.0.*no token"):
            async with BridgeServer(host="0.0.0.0") as server:
                assert _bound_host(server) == "0.0.0.0"

    asyncio.run(main())


def test_non_loopback_with_token_says_so() -> None:
    async def main() -> None:
        with pytest.warns(ExposedServerWarning, match="token required"):
            async with BridgeServer(host="0.0.0.0", token="t"):
                pass

    asyncio.run(main())


def test_is_loopback() -> None:
    assert is_loopback("127.0.0.1")
    assert is_loopback("127.1.2.3")
    assert is_loopback("::1")
    assert is_loopback("localhost")
    assert is_loopback("[::1]")
    assert not is_loopback("0.0.0.0")
    assert not is_loopback("::")
    assert not is_loopback("10.0.0.1")
    assert not is_loopback("example.com")


def test_session_binds_loopback_by_default() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ExposedServerWarning)
        with Session("demo") as session:
            assert session.url.startswith("ws://127.0.0.1:")


def test_session_on_all_interfaces_warns() -> None:
    with pytest.warns(ExposedServerWarning), Session("demo", host="0.0.0.0") as session:
        assert session.url.startswith("ws://0.0.0.0:")


def _serve_stderr(*extra: str) -> tuple[str, str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--port", "0", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    first = proc.stdout.readline()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    return first, err


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_serve_warns_only_for_an_explicit_exposed_host() -> None:
    first, err = _serve_stderr()
    assert "ws://127.0.0.1:" in first
    assert "warning" not in err.lower()
    first, err = _serve_stderr("--host", "0.0.0.0")
    assert "ws://0.0.0.0:" in first
    warning_lines = [line for line in err.splitlines() if "warning" in line.lower()]
    assert len(warning_lines) == 1, err
    assert "0.0.0.0" in warning_lines[0]
