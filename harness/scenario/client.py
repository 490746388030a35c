"""Starting, watching and stopping the client under test.

The client command starts in its own process group (so ``ros2 launch`` and whatever it spawns
can be stopped together) with ``HARNESS_ROSBRIDGE_URL`` in its environment, once the bridge
is listening. :func:`run_client` then watches four things until one of them ends the run:
the client exiting, the client not connecting within the readiness timeout, the simulation
reaching the sim-time limit, and the wall-time limit. Whatever ended it, the whole process
group is stopped with escalation: SIGTERM, then SIGKILL after a grace period, and the call
returns only when no process of the group is left (zombies awaiting a reaper excepted).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Protocol

from harness.scenario.client_warm import active_pool
from harness.scenario.results import ClientOutcome, ClientStatus
from harness.scenario.scenario import ClientSpec

__all__ = ["BridgeHost", "ClientProcess", "group_alive", "run_client", "stop_group"]

URL_ENV = "HARNESS_ROSBRIDGE_URL"
_POLL = 0.02


class ClientProcess(Protocol):
    """The client's process as the supervisor uses it: a ``subprocess.Popen``, or a
    :class:`~harness.scenario.client_warm.WarmProcess` (a client started warm)."""

    @property
    def pid(self) -> int: ...

    def poll(self) -> int | None: ...

    def wait(self, timeout: float | None = None) -> int: ...


class BridgeHost(Protocol):
    """What a run offers the supervisor: the bridge URL (listening before :func:`run_client`
    is called), whether a client has connected, and the simulation time reached."""

    @property
    def url(self) -> str:
        """``ws://host:port`` of the bridge."""
        ...

    def client_connected(self) -> bool:
        """True once at least one client connection was accepted."""
        ...

    def sim_time(self) -> float:
        """Simulation seconds reached so far."""
        ...


def group_alive(pgid: int) -> bool:
    """Whether any non-zombie process is in process group ``pgid`` (Linux: from /proc)."""
    proc = Path("/proc")
    if not proc.is_dir():
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        # "pid (comm) state ppid pgrp ...": comm may hold spaces and parentheses.
        fields = stat[stat.rfind(")") + 2 :].split()
        if len(fields) >= 3 and int(fields[2]) == pgid and fields[0] not in ("Z", "X"):
            return True
    return False


def _wait_group(pgid: int, seconds: float) -> bool:
    """Wait up to ``seconds`` for the group to be empty; True when it is."""
    deadline = time.monotonic() + seconds
    pause = threading.Event()
    while group_alive(pgid):
        if time.monotonic() >= deadline:
            return False
        pause.wait(_POLL)
    return True


def stop_group(process: ClientProcess, grace: float) -> None:
    """Stop ``process`` and every process in its group: SIGTERM, then SIGKILL for whatever is
    left after ``grace`` seconds; reaps the leader."""
    pgid = process.pid  # start_new_session=True: the leader's pid is the group id
    deadline = time.monotonic() + grace
    try:
        os.killpg(pgid, signal.SIGTERM)
    except ProcessLookupError:  # no process left in the group, not even a zombie
        process.wait()
        return
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(timeout=grace)
    if not _wait_group(pgid, max(0.0, deadline - time.monotonic())):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pgid, signal.SIGKILL)
        process.wait()
        _wait_group(pgid, 10.0)


def _tail(path: Path, lines: int = 3) -> str:
    try:
        text = path.read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    tail = " | ".join(line.strip() for line in text[-lines:] if line.strip())
    return f" (last output: {tail[:300]})" if tail else ""


def run_client(
    spec: ClientSpec,
    host: BridgeHost,
    sim_time_limit: float,
    log_path: Path,
    grace: float = 3.0,
) -> ClientOutcome:
    """Run the client under test against ``host`` until it exits, fails to connect in time,
    the sim-time limit is reached or the wall-time limit passes; nothing is left running.
    Inside :func:`harness.scenario.client_warm.warm_clients`, a Python client may start warm
    (what it sees is what a cold start gives it: see that module)."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, **spec.env, URL_ENV: host.url}
    start = time.monotonic()
    pool = active_pool()
    with log_path.open("wb") as log:
        try:
            process: ClientProcess | None = None
            if pool is not None:
                process = pool.start(spec.command, spec.cwd, env, log)
            if process is None:
                process = subprocess.Popen(
                    list(spec.command),
                    cwd=spec.cwd,
                    env=env,
                    stdin=subprocess.DEVNULL,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                )
        except OSError as exc:
            return ClientOutcome(
                "exited",
                None,
                f"client command {spec.command[0]!r} could not start: {exc}",
                log_path,
            )
        try:
            status, code, reason = _watch(process, spec, host, sim_time_limit, start)
        finally:
            stop_group(process, grace)
    wall = time.monotonic() - start
    if status == "exited" and code != 0:
        reason += _tail(log_path)
    return ClientOutcome(status, code, reason, log_path, wall)


def _watch(
    process: ClientProcess,
    spec: ClientSpec,
    host: BridgeHost,
    sim_time_limit: float,
    start: float,
) -> tuple[ClientStatus, int | None, str]:
    connected = False
    while True:
        code = process.poll()
        connected = connected or host.client_connected()
        elapsed = time.monotonic() - start
        if code is not None:
            if code == 0 and not connected:
                return (
                    "not_ready",
                    code,
                    "client exited with code 0 without connecting to the bridge",
                )
            if code == 0:
                return "exited", 0, f"client exited with code 0 after {elapsed:.2f} s wall"
            what = f"signal {-code}" if code < 0 else f"code {code}"
            return "exited", code, f"client exited with {what}"
        if host.sim_time() >= sim_time_limit:
            return "sim_limit", None, f"sim-time limit {sim_time_limit:g} s reached"
        if not connected and elapsed >= spec.readiness_timeout:
            return (
                "not_ready",
                None,
                f"client did not connect to {host.url} within {spec.readiness_timeout:g} s",
            )
        if elapsed >= spec.wall_timeout:
            return (
                "wall_timeout",
                None,
                f"client still running after the wall-time limit {spec.wall_timeout:g} s "
                f"(sim time {host.sim_time():.3f} s of {sim_time_limit:g} s)",
            )
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(timeout=_POLL)
