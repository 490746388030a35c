"""A warm interpreter for Python clients: ``python SCRIPT ARGS`` without the interpreter's
start and its imports, for runs that start the same client many times (``harness explore``).

Inside :func:`warm_clients`, :func:`harness.scenario.client.run_client` hands a command
``<this interpreter> SCRIPT [ARGS]`` (a ``python``/``python3`` client command, see
:mod:`harness.scenario.session_runner`) to a pre-started process per (script, folder)
(:mod:`harness.scenario.client_zygote`) that has imported what the previous client of that
script imported, from the standard library and site-packages only. It forks a child per run;
the child is what a cold start gives the client:

- the same argv (``sys.argv``, ``sys.orig_argv``), environment (``os.environ`` and the C
  environment, in the same order), working folder, ``sys.path`` (the script's real folder
  first), stdin/stdout/stderr (the same descriptors a cold start gets), its own session and
  process group (stopped the same way);
- ``__name__ == "__main__"`` in a fresh ``__main__`` module (``__file__`` absolute,
  ``__loader__``, ``__builtins__`` as a cold start sets them): the script's own module state
  is always new, and so are the client's own modules (never imported ahead);
- an uncaught exception printed as the interpreter prints it and exit status 1; exit status,
  atexit handlers and non-daemon threads as at a cold interpreter's end; ``random`` and
  ``numpy.random`` reseeded from the OS as a cold start seeds them.

Not the same as a cold start, by design: modules of the standard library and site-packages
may already be imported (their import-time work done once, with the first client's
``sys.argv``), the string hash seed is the warm process's (one random seed per warm process,
not per run), one more descriptor is open (close-on-exec: what the client runs with ``exec``
does not get it), and the client's parent process is the warm process. The warm process
refuses a fork whenever an import could tell: an environment variable read during its imports
(or at interpreter start-up: ``PYTHON*``, ``LC_*``, ``LANG``, ``HOME``, ``PATH``, ``TZ``)
differs from the first client's, the folder differs, or an import started a thread; the
client then starts cold, as does any other command. The explore tests check that a warm
client's recording is byte-identical to a cold ``harness run``'s.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

__all__ = ["WarmPool", "WarmProcess", "active_pool", "warm_clients"]

_ZYGOTE = Path(__file__).with_name("client_zygote.py")
_LOCAL = threading.local()


class WarmProcess:
    """A client forked by a warm interpreter: the part of ``subprocess.Popen`` that
    :func:`harness.scenario.client.run_client` and
    :func:`~harness.scenario.client.stop_group` use (``pid``, ``poll``, ``wait``,
    ``returncode``); its exit status comes from the warm process, its parent."""

    def __init__(self, zygote: _Zygote, pid: int) -> None:
        self.pid = pid
        self.returncode: int | None = None
        self._zygote = zygote

    def poll(self) -> int | None:
        """The exit status once the child ended (negative: the signal), else None."""
        if self.returncode is None:
            self._take(0.0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        """Wait for the child's end; ``subprocess.TimeoutExpired`` after ``timeout``."""
        if self.returncode is None:
            self._take(timeout)
        if self.returncode is None:
            raise subprocess.TimeoutExpired([str(self.pid)], timeout or 0.0)
        return self.returncode

    def _take(self, timeout: float | None) -> None:
        message = self._zygote.receive(timeout)
        if message is None:
            return
        if message.get("op") == "exited" and message.get("pid") == self.pid:
            self.returncode = int(message["code"])
        else:  # the warm process died or answered out of turn: the child is gone with it
            self.returncode = -9
            self._zygote.close()


@dataclass
class _Zygote:
    """One warm process (see the module docstring) and our end of its socket."""

    process: subprocess.Popen[bytes]
    sock: socket.socket
    busy: bool = False
    dead: bool = False

    @classmethod
    def start(cls, script: str, cwd: Path, env: Mapping[str, str]) -> _Zygote:
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            process = subprocess.Popen(
                [sys.executable, str(_ZYGOTE), str(theirs.fileno()), script],
                cwd=cwd,
                env=dict(env),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                pass_fds=(theirs.fileno(),),
            )
        finally:
            theirs.close()
        return cls(process, ours)

    def receive(self, timeout: float | None) -> dict[str, Any] | None:
        """The next message (None: none within ``timeout``); EOF gives ``{"op": "eof"}``."""
        ready, _, _ = select.select([self.sock], [], [], timeout)
        if not ready:
            return None
        try:
            data = self.sock.recv(1 << 16)
        except OSError:
            data = b""
        if not data:
            self.dead = True
            return {"op": "eof"}
        message: dict[str, Any] = json.loads(data)
        return message

    def run(
        self, argv: list[str], env: Mapping[str, str], cwd: Path, stdout: BinaryIO
    ) -> WarmProcess | str:
        """Fork a child; the reason when the warm process refuses (or is gone)."""
        request = {"op": "run", "argv": argv, "env": dict(env), "cwd": str(cwd)}
        with open(os.devnull, "rb") as devnull:
            fds = [devnull.fileno(), stdout.fileno(), stdout.fileno()]
            try:
                socket.send_fds(self.sock, [json.dumps(request).encode()], fds)
            except OSError as exc:
                self.close()
                return f"the warm interpreter is gone ({exc})"
        message = self.receive(None) or {"op": "eof"}
        if message["op"] == "started":
            return WarmProcess(self, int(message["pid"]))
        if message["op"] == "refused":
            return str(message["reason"])
        self.close()
        return "the warm interpreter is gone"

    def close(self) -> None:
        self.dead = True
        with contextlib.suppress(OSError):
            self.sock.close()
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()


@dataclass
class WarmPool:
    """The warm interpreters of one :func:`warm_clients` block, one per (script, folder);
    ``refusals``: why runs started cold (one line each, the most recent last);
    ``forked``: runs that started warm."""

    zygotes: dict[tuple[str, str], _Zygote] = field(default_factory=dict)
    refusals: list[str] = field(default_factory=list)
    forked: int = 0

    def start(
        self, command: tuple[str, ...], cwd: Path, env: Mapping[str, str], stdout: BinaryIO
    ) -> WarmProcess | None:
        """The client ``command`` forked warm, or None: start it cold (another kind of
        command, or a refusal: see the module docstring)."""
        if len(command) < 2 or command[0] != sys.executable or command[1].startswith("-"):
            return None
        if not (cwd / command[1]).is_file():
            return None  # a cold start says what is wrong with it
        key = (command[1], str(cwd))
        zygote = self.zygotes.get(key)
        if zygote is not None and zygote.dead:
            zygote.close()
            zygote = None
        if zygote is None:
            zygote = _Zygote.start(command[1], cwd, env)
            self.zygotes[key] = zygote
        started = zygote.run(list(command), env, cwd, stdout)
        if isinstance(started, str):
            self.refusals.append(f"{command[1]}: started cold: {started}")
            del self.refusals[:-20]
            return None
        self.forked += 1
        return started

    def close(self) -> None:
        """Stop every warm process."""
        for zygote in self.zygotes.values():
            zygote.close()
        self.zygotes.clear()


def active_pool() -> WarmPool | None:
    """The pool of the innermost :func:`warm_clients` block of this thread (None: clients
    start cold)."""
    pool: WarmPool | None = getattr(_LOCAL, "pool", None)
    return pool


@contextlib.contextmanager
def warm_clients(enabled: bool = True) -> Iterator[WarmPool | None]:
    """Python clients started in this block (this thread) start warm (see the module
    docstring); the warm processes stop at its end. ``enabled`` False: a block that changes
    nothing (clients start cold), the value None."""
    if not enabled:
        yield None
        return
    previous = active_pool()
    pool = WarmPool()
    _LOCAL.pool = pool
    try:
        yield pool
    finally:
        _LOCAL.pool = previous
        pool.close()
