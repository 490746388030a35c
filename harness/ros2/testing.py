"""Helpers for tests of ROS 2 nodes against the harness (used by the project's tests and the
example in ``examples/ros2_node``): run a node script in the ROS 2 interpreter on a session's
domain, and a rosbridge-server-rs process for the client-mode route. Wall-clock timeouts here
bound start-up and readiness only."""

from __future__ import annotations

import json
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from harness.ros2.env import Ros2Install, rosbridge_server_rs
from harness.ros2.errors import Ros2Error

__all__ = ["free_port", "rosbridge_server", "run_node", "start_node"]


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def start_node(
    install: Ros2Install, domain_id: int, script: str | Path, args: Sequence[str] = ()
) -> subprocess.Popen[str]:
    """Start ``script`` (a file) or Python code (a ``str``) in the ROS 2 interpreter."""
    head = [str(script)] if isinstance(script, Path) else ["-c", script]
    return subprocess.Popen(
        [str(install.python), *head, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=install.environment(domain_id),
    )


def run_node(
    install: Ros2Install,
    domain_id: int,
    script: str | Path,
    args: Sequence[str] = (),
    timeout: float = 120.0,
) -> dict[str, Any]:
    """Run a node (file or code, as :func:`start_node`) to its end; returns the JSON object
    of its last stdout line. Raises :class:`Ros2Error` with its stderr when it fails."""
    process = start_node(install, domain_id, script, args)
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
    lines = out.strip().splitlines()
    if process.returncode != 0 or not lines:
        raise Ros2Error(
            f"{script} exited {process.returncode}: {' | '.join(err.strip().splitlines()[-8:])}"
        )
    result: dict[str, Any] = json.loads(lines[-1])
    return result


@contextmanager
def rosbridge_server(
    install: Ros2Install, domain_id: int, port: int | None = None, timeout: float = 30.0
) -> Iterator[str]:
    """rosbridge-server-rs on 127.0.0.1 (``port``, or a free one) on ``domain_id``; yields
    its ``ws://`` URL once it accepts connections; stops it at the end."""
    port = free_port() if port is None else port
    argv, env = rosbridge_server_rs(install, port, domain_id)
    # its log goes to a file: a pipe nobody reads would fill and stall the server
    with tempfile.TemporaryFile("w+") as log:
        process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=log, text=True)
        try:
            deadline = time.monotonic() + timeout
            while True:
                if process.poll() is not None:
                    log.seek(0)
                    raise Ros2Error(f"rosbridge-server-rs exited: {log.read()[-800:]}")
                with socket.socket() as sock:
                    if sock.connect_ex(("127.0.0.1", port)) == 0:
                        break
                if time.monotonic() > deadline:
                    raise Ros2Error(f"rosbridge-server-rs did not listen on {port} in {timeout} s")
                time.sleep(0.05)  # readiness polling of another process, not simulation time
            yield f"ws://127.0.0.1:{port}"
        finally:
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
