"""The routes from the command line and start-up without ROS (no ROS 2 needed here)."""

from __future__ import annotations

import asyncio
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest

from harness.rosbridge import BridgeServer


@pytest.fixture
def external_server() -> Iterator[str]:
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, name="external-rosbridge")
    thread.start()
    server = BridgeServer()
    try:
        yield asyncio.run_coroutine_threadsafe(server.start(), loop).result()
    finally:
        asyncio.run_coroutine_threadsafe(server.stop(), loop).result()
        loop.call_soon_threadsafe(loop.stop)
        thread.join()
        loop.close()


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_serve_connect_runs_as_a_client_and_prints_the_link_summary(external_server: str) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "harness", "serve", "--clock", "lockstep", "--connect",
         external_server + "/?token=secret"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    first = proc.stdout.readline()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert first.startswith(f"harness serve: connected to {external_server}/?token=***"), first
    assert "secret" not in first
    assert "harness serve: upstream: send failures 0, reconnects 0, refused 0" in out


@pytest.mark.slow
def test_serve_connect_to_nothing_is_one_line() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harness", "serve", "--connect", "ws://127.0.0.1:9"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "harness serve: error: could not connect to the rosbridge server ws://127.0.0.1:9 "
        "within 10 s"
    ]


@pytest.mark.slow
def test_a_session_without_ros2_imports_nothing_of_it() -> None:
    code = (
        "import sys; from harness.session import Session\n"
        "with Session('demo') as s: s.step(1)\n"
        "print(sorted(m for m in sys.modules if m.startswith(('harness.ros2', 'rclpy'))))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert done.stdout.strip() == "[]"
