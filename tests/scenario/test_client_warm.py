"""Python clients started warm (harness.scenario.client_warm): what the client sees is what a
cold ``python SCRIPT ARGS`` gives it, the imports are kept warm, a fork that could differ from
a cold start is refused, and a warm client is stopped like a cold one.

Real processes against a real WebSocket endpoint on 127.0.0.1 (StandInHost); the probe client
writes what it sees to a JSON file."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from harness.scenario import ClientSpec, run_client, warm_clients
from tests.scenario.scenario_testlib import CLIENT, process_gone
from tests.scenario.standins import StandInHost

PROBE = '''"""Writes what it sees to argv[1] (JSON); argv[2]: ok | exit3 | raise | interrupt."""
import sys

WARM = "websockets" in sys.modules  # before any import of its own

import json
import os
import random

import helper
from websockets.sync.client import connect

out, mode = sys.argv[1], sys.argv[2]
main = sys.modules["__main__"]
view = {
    "warm": WARM,
    "argv": sys.argv,
    "orig_argv": sys.orig_argv,
    "name": __name__,
    "main_is_module": main.__dict__ is globals(),
    "file": __file__,
    "globals": sorted(k for k in globals() if k.startswith("__")),
    "loader": type(__loader__).__name__,
    "spec": repr(__spec__),
    "builtins": type(__builtins__).__name__,
    "path": sys.path,
    "cwd": os.getcwd(),
    "environ": list(os.environ.items()),
    "getenv": os.getenv("EXTRA"),
    "session_leader": os.getsid(0) == os.getpid() == os.getpgid(0),
    "stdin": sys.stdin.read(),
    "stdio": [os.readlink(f"/proc/self/fd/{fd}") for fd in (0, 1, 2)],
    "line_buffering": sys.stdout.line_buffering,
    "helper_imports": helper.IMPORTS,
    "executable": sys.executable,
    "flags": repr(sys.flags),
    "random": random.random(),
}
with open(out, "w") as f:
    json.dump(view, f)
print("probe ran", flush=True)
with connect(os.environ["HARNESS_ROSBRIDGE_URL"]):
    pass
if mode == "exit3":
    sys.exit(3)
if mode == "raise":
    def fail():
        raise ValueError("the probe fails")
    fail()
if mode == "interrupt":
    raise KeyboardInterrupt
'''

HELPER = """IMPORTS = 0
IMPORTS += 1  # a fresh module per run: always 1
"""


def _probe(tmp_path: Path) -> Path:
    folder = tmp_path / "clients"
    folder.mkdir()
    (folder / "probe.py").write_text(PROBE)
    (folder / "helper.py").write_text(HELPER)
    return folder / "probe.py"


def _run(tmp_path: Path, host: StandInHost, name: str, mode: str = "ok", **env: str) -> Any:
    command = (sys.executable, "clients/probe.py", str(tmp_path / f"{name}.json"), mode)
    spec = ClientSpec(command, tmp_path, {"EXTRA": "yes", **env}, 20.0, 60.0)
    log = tmp_path / f"{name}.log"
    outcome = run_client(spec, host, 10.0, log)
    view = json.loads((tmp_path / f"{name}.json").read_text())
    text = log.read_text().replace(str(log), "LOG")
    return outcome, view, text


def _same(cold: dict[str, Any], warm: dict[str, Any]) -> dict[str, Any]:
    """The fields where a warm view differs from the cold one (the log paths aside)."""
    skip = {"warm", "random", "stdio", "argv", "orig_argv"}
    diff = {k: (cold[k], warm[k]) for k in cold if k not in skip and cold[k] != warm[k]}
    return diff


def test_a_warm_client_sees_what_a_cold_start_gives_it(tmp_path: Path) -> None:
    _probe(tmp_path)
    with StandInHost() as host:
        _, cold, cold_log = _run(tmp_path, host, "cold")
        with warm_clients() as pool:
            runs = [_run(tmp_path, host, f"warm{i}") for i in range(3)]
    assert pool.forked == 3, pool.refusals
    assert not pool.refusals
    for i, (outcome, view, log) in enumerate(runs):
        assert outcome.exit_code == 0, outcome.reason
        assert outcome.passed, outcome.reason
        assert _same(cold, view) == {}
        assert view["argv"] == ["clients/probe.py", str(tmp_path / f"warm{i}.json"), "ok"]
        assert view["orig_argv"][0] == sys.executable
        assert view["orig_argv"][1:] == view["argv"]
        assert view["stdio"][0] == "/dev/null"
        assert view["stdio"][1:] == [str(tmp_path / f"warm{i}.log")] * 2
        assert log == cold_log == "probe ran\n"
    assert cold["warm"] is False
    assert cold["name"] == "__main__"
    assert cold["helper_imports"] == 1
    # the first warm run taught the warm process the client's imports: the next ones have them
    assert [view["warm"] for _, view, _ in runs] == [False, True, True]
    # the random module is seeded anew for each run, as a cold start seeds it
    assert len({view["random"] for _, view, _ in runs}) == 3


def test_exit_status_and_traceback_are_a_cold_start_s(tmp_path: Path) -> None:
    _probe(tmp_path)
    with StandInHost() as host:
        modes = ("exit3", "raise", "interrupt")
        cold = [_run(tmp_path, host, f"cold-{m}", m) for m in modes]
        with warm_clients() as pool:
            warm = [_run(tmp_path, host, f"warm-{m}", m) for m in modes]
    assert pool.forked == 3
    for (c_out, _, c_log), (w_out, _, w_log) in zip(cold, warm, strict=True):
        assert (w_out.status, w_out.exit_code) == (c_out.status, c_out.exit_code)
        assert w_log == c_log
    assert [o.exit_code for o, _, _ in warm] == [3, 1, -2]
    assert "client_zygote" not in warm[1][2]
    assert 'probe.py", line' in warm[1][2]
    assert "ValueError: the probe fails" in warm[1][2]


def test_a_variable_read_while_importing_that_differs_starts_cold(tmp_path: Path) -> None:
    """websockets reads WEBSOCKETS_MAX_LINE_LENGTH when imported: a run that changes it must
    import websockets anew (cold); so must a run that changes LANG (read at start-up)."""
    _probe(tmp_path)
    with StandInHost() as host, warm_clients() as pool:
        _run(tmp_path, host, "first")
        _, same, _ = _run(tmp_path, host, "same", EXTRA2="x")  # read by nobody: warm
        assert pool.forked == 2
        assert same["warm"]
        _, other, _ = _run(tmp_path, host, "other", WEBSOCKETS_MAX_LINE_LENGTH="16384")
        assert pool.forked == 2
        assert "WEBSOCKETS_MAX_LINE_LENGTH differs" in pool.refusals[-1]
        assert other["warm"] is False
        assert ("WEBSOCKETS_MAX_LINE_LENGTH", "16384") in [tuple(e) for e in other["environ"]]
        _, lang, _ = _run(tmp_path, host, "lang", LANG="C")
        assert "LANG differs" in pool.refusals[-1]
        assert lang["warm"] is False
        _, again, _ = _run(tmp_path, host, "again")
        assert pool.forked == 3
        assert again["warm"]


def test_a_warm_client_is_stopped_with_its_process_group(tmp_path: Path) -> None:
    """A client ignoring SIGTERM with a child ignoring it too: both are gone after the run."""
    pidfile = tmp_path / "pids"
    spec = ClientSpec((sys.executable, str(CLIENT), "stubborn", str(pidfile)), tmp_path, {}, 20, 2)
    with StandInHost() as host, warm_clients() as pool:
        outcome = run_client(spec, host, 10.0, tmp_path / "client.log", grace=0.5)
    assert pool.forked == 1
    assert outcome.status == "wall_timeout"
    pids = [int(p) for p in pidfile.read_text().split()]
    assert len(pids) == 2
    assert all(process_gone(p) for p in pids)
