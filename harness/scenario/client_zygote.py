"""The warm interpreter's own process (a "zygote"): run by path, standard library only.

Started by :mod:`harness.scenario.client_warm` as ``python client_zygote.py FD SCRIPT`` in the
client's folder with the first client's environment; ``FD`` is its end of a ``SOCK_SEQPACKET``
socket pair. It then serves, one at a time:

- ``{"op": "run", "argv", "env", "cwd"}`` with the client's stdin, stdout and stderr as
  passed descriptors: it forks a child that becomes what ``python SCRIPT ARGS`` would have
  been (see :func:`_child`), answers ``{"op": "started", "pid"}`` once the child leads its
  own session, and ``{"op": "exited", "pid", "code"}`` once it reaped it; or answers
  ``{"op": "refused", "reason"}`` when a fork could differ from a cold start (an environment
  variable it read while importing differs, another folder, threads in this process);
- after each child, it imports what the child imported (modules of the standard library and
  of site-packages only: never the client's own), each environment variable read meanwhile
  noted (:class:`_Tracked`), so the next child starts with them loaded.

Nothing here imports the harness: the children must not see its modules.
"""

from __future__ import annotations

import builtins
import contextlib
import json
import os
import signal
import socket
import sys
import sysconfig
import traceback
import types
from collections.abc import Iterator
from importlib import import_module
from importlib.machinery import SourceFileLoader
from typing import Any, ClassVar

_STARTUP_PREFIXES = ("PYTHON", "LC_")
_STARTUP_KEYS = frozenset({"LANG", "LANGUAGE", "HOME", "TZ", "PATH"})
"""Variables the interpreter (or ``site``) reads before any code of ours runs: a child whose
environment differs in one of them starts cold."""


class _Tracked(os._Environ[str]):
    """``os.environ`` noting the keys read (iterating it reads them all)."""

    read: ClassVar[set[str]] = set()
    everything: ClassVar[bool] = False

    def __getitem__(self, key: str) -> str:
        _Tracked.read.add(key)
        return str(super().__getitem__(key))

    def __iter__(self) -> Iterator[str]:
        _Tracked.everything = True
        return super().__iter__()


def _track_environ() -> None:
    env: Any = os.environ
    # the same variables (the same dict), their reads noted
    os.environ = _Tracked(  # noqa: B003
        env._data, env.encodekey, env.decodekey, env.encodevalue, env.decodevalue
    )


def _library_roots() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    keys = ("stdlib", "platstdlib", "purelib", "platlib")
    return tuple(os.path.realpath(paths[k]) + os.sep for k in keys if k in paths)


def _warmable(name: str, module: Any, roots: tuple[str, ...]) -> bool:
    """A module of the standard library or site-packages (not the client's own)."""
    if name == "__main__" or name.startswith("_frozen") or module is None:
        return False
    file = getattr(module, "__file__", None)
    if file is None:
        return name in sys.builtin_module_names
    return os.path.realpath(str(file)).startswith(roots)


def _learn(names: list[str]) -> None:
    """Import ``names`` (what the last child imported); failures are ignored (that child
    imports it itself)."""
    for name in names:
        if name in sys.modules:
            continue
        try:
            import_module(name)
        except BaseException:  # an import the child makes on its own
            sys.modules.pop(name, None)


def _threads() -> int:
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        import threading

        return threading.active_count()


def _refusal(request: dict[str, Any], env: dict[str, str], cwd: str) -> str | None:
    """Why a fork could differ from a cold start (None: it cannot)."""
    if request["cwd"] != cwd:
        return f"another folder ({request['cwd']})"
    if _threads() > 1:
        return "the warm interpreter has threads (an import started one)"
    wanted: dict[str, str] = request["env"]
    changed = {k for k in set(wanted) | set(env) if wanted.get(k) != env.get(k)}
    if _Tracked.everything and changed:
        return "an import read the whole environment and the environment differs"
    for key in sorted(changed):
        if key in _Tracked.read or key in _STARTUP_KEYS or key.startswith(_STARTUP_PREFIXES):
            return f"environment variable {key} differs and is read at start-up"
    return None


def _send(sock: socket.socket, message: dict[str, Any]) -> None:
    sock.sendmsg([json.dumps(message).encode()])


def _child(
    sock: socket.socket, request: dict[str, Any], fds: list[int], ready: int, report: int
) -> None:
    """Become ``python SCRIPT ARGS`` (never returns: ends the interpreter)."""
    os.setsid()  # as start_new_session=True: the child leads its process group
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
    for fd in fds:
        if fd > 2:
            os.close(fd)
    os.close(sock.detach())
    os.close(ready)  # the parent reads EOF: the child leads its session
    env: dict[str, str] = request["env"]
    os.environ.clear()
    os.environ.update(env)
    argv: list[str] = request["argv"]  # [executable, script, *args]
    script = argv[1]
    path = os.path.abspath(script)
    sys.argv = argv[1:]
    sys.orig_argv = list(argv)
    if "numpy.random" in sys.modules:  # its global state was seeded at import: reseed as cold
        sys.modules["numpy.random"].seed()
    known = set(sys.modules)  # what the warm process has: only the rest is news
    interrupted = False

    def tell() -> None:
        roots = _library_roots()
        names = [
            n for n, m in list(sys.modules.items()) if n not in known and _warmable(n, m, roots)
        ]
        with contextlib.suppress(OSError):
            os.write(report, json.dumps(names).encode())
        os.close(report)
        if interrupted:  # as a cold interpreter ends on an uncaught KeyboardInterrupt
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGINT)

    import atexit

    atexit.register(tell)  # registered first: runs after the script's own handlers
    main = types.ModuleType("__main__")
    main.__dict__.update(
        __file__=path,
        __cached__=None,
        __loader__=SourceFileLoader("__main__", path),
        __spec__=None,
        __builtins__=builtins,
        __annotations__={},
    )
    sys.modules["__main__"] = main
    with open(path, "rb") as file:
        source = file.read()
    try:
        code = compile(source, path, "exec", dont_inherit=True)
        exec(code, main.__dict__)
    except SystemExit:
        raise
    except BaseException as exc:  # as the interpreter prints it, without this file's frames
        tb = exc.__traceback__
        while tb is not None and tb.tb_frame.f_code.co_filename != path:
            tb = tb.tb_next
        if isinstance(exc, SyntaxError):
            tb = None
        sys.excepthook(type(exc), exc.with_traceback(tb), tb)
        interrupted = isinstance(exc, KeyboardInterrupt)
        raise SystemExit(1) from None
    raise SystemExit(0)


def _serve(sock: socket.socket, env: dict[str, str]) -> None:
    cwd = os.getcwd()
    while True:
        try:
            data, fds, _flags, _addr = socket.recv_fds(sock, 1 << 20, 3)
        except OSError:
            return
        if not data:
            return
        request = json.loads(data)
        reason = _refusal(request, env, cwd)
        if reason is not None or len(fds) != 3:
            for fd in fds:
                os.close(fd)
            _send(sock, {"op": "refused", "reason": reason or "no stdio descriptors"})
            continue
        ready_r, ready_w = os.pipe()
        report_r, report_w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(ready_r)
            os.close(report_r)
            _child(sock, request, fds, ready_w, report_w)
        os.close(ready_w)
        os.close(report_w)
        for fd in fds:
            os.close(fd)
        os.read(ready_r, 1)  # EOF once the child has its own session and closed the rest
        os.close(ready_r)
        _send(sock, {"op": "started", "pid": pid})
        _pid, status = os.waitpid(pid, 0)
        chunks = []
        while chunk := os.read(report_r, 65536):
            chunks.append(chunk)
        os.close(report_r)
        _send(sock, {"op": "exited", "pid": pid, "code": os.waitstatus_to_exitcode(status)})
        try:
            names = json.loads(b"".join(chunks) or b"[]")
        except ValueError:
            names = []
        _learn([n for n in names if isinstance(n, str)])


def main() -> None:
    """``client_zygote.py FD SCRIPT``: serve the socket ``FD`` for ``SCRIPT``'s children."""
    fd, script = int(sys.argv[1]), sys.argv[2]
    sys.path[0] = os.path.dirname(os.path.realpath(os.path.abspath(script)))
    sys.argv = [script]
    env = dict(os.environ)  # before tracking: this copy reads every variable
    _track_environ()
    sock = socket.socket(fileno=fd)
    try:
        _serve(sock, env)
    except Exception:  # the harness sees EOF and runs clients cold
        traceback.print_exc()


if __name__ == "__main__":
    main()
