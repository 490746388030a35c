"""Per-test overhead of the ``harness_session`` fixture, beside the bare Session.

An in-process ``pytest`` run of N generated tests that each take ``harness_session`` (demo
robot on its table, rosbridge server on a free port, recording on, collision and joint-limit
loggers) and do nothing else, against the same run of N tests that take no fixture: the
difference per test is the fixture's set-up + teardown (recording kept: never, so the file is
also deleted). In the same process: ``Session("demo", record_to=...)`` then ``close()`` alone
(what the plugin adds on top of it is marker merging, logger set-up and file handling).

The limits are the original framework's simulator start-ups, paid once per test run: Unreal
Engine 6 s and Gazebo 3 s (thesis Table 5.4). Target: < 100 ms per test.
"""

from __future__ import annotations

import io
import itertools
import tempfile
import time
from contextlib import redirect_stdout
from importlib.metadata import entry_points
from pathlib import Path

import pytest
from common import Row

from harness.session import Session

_UNREAL_STARTUP_S = 6.0
_GAZEBO_STARTUP_S = 3.0
_MIN_RATIO = 0.5
"""A test's harness_session may cost at most twice a bare ``Session("demo")`` + ``close()``
measured in the same run (measured 0.85 on the reference machine)."""
_RUNS = itertools.count()


def _plugin_args() -> list[str]:
    installed = any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))
    return [] if installed else ["-p", "harness.pytest_plugin"]


def _suite_seconds(folder: Path, body: str, n: int) -> float:
    """Wall seconds of an in-process pytest run of ``n`` copies of ``body``."""
    tests = "\n".join(body.format(i=i) for i in range(n))
    for old in folder.glob("test_*.py"):
        old.unlink()
    # A new module name every run: pytest would otherwise reuse the module imported before.
    path = folder / f"test_generated_{next(_RUNS)}.py"
    path.write_text(tests)
    args = [
        str(path),
        "-q",
        "-p",
        "no:cacheprovider",
        "--import-mode=importlib",
        f"--harness-record-dir={folder / 'recordings'}",
        "--harness-keep-recordings=never",
        *_plugin_args(),
    ]
    out = io.StringIO()
    start = time.perf_counter()
    with redirect_stdout(out):
        code = pytest.main(args)
    seconds = time.perf_counter() - start
    if code != 0 or f"{n} passed" not in out.getvalue():
        raise RuntimeError(f"generated suite failed ({code}):\n{out.getvalue()[-2000:]}")
    return seconds


def _bare_session_seconds(folder: Path, n: int) -> float:
    start = time.perf_counter()
    for i in range(n):
        Session("demo", record_to=folder / f"bare-{i}.mcap").close()
    return (time.perf_counter() - start) / n


def run(quick: bool) -> list[Row]:
    n = 10 if quick else 40
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "pytest.ini").write_text("[pytest]\n")
        bare_body = "def test_{i}():\n    pass\n"
        fixture_body = "def test_{i}(harness_session):\n    pass\n"
        # Warm pytest's own first-run costs and the harness imports for both sides.
        _suite_seconds(folder, bare_body, 2)
        _suite_seconds(folder, fixture_body, 2)
        repeats = 2 if quick else 3
        bare_suite = min(_suite_seconds(folder, bare_body, n) for _ in range(repeats))
        fixture_suite = min(_suite_seconds(folder, fixture_body, n) for _ in range(repeats))
        bare_session = _bare_session_seconds(folder, n)
    per_test = (fixture_suite - bare_suite) / n
    note = (
        f"{n} tests: {fixture_suite:.2f} s with harness_session, {bare_suite:.2f} s without; "
        f"bare Session() + close() {bare_session * 1e3:.1f} ms"
    )
    return [
        Row(
            "harness_session per test (set-up + teardown, demo, recording) vs Unreal start-up",
            per_test,
            _UNREAL_STARTUP_S,
            "s",
            "(info: Unreal 6 s per run)",
            True,
            higher_is_better=False,
            note=note,
        ),
        Row(
            "harness_session per test vs Gazebo start-up",
            per_test,
            _GAZEBO_STARTUP_S,
            "s",
            "(info: Gazebo 3 s per run)",
            True,
            higher_is_better=False,
        ),
        Row(
            "harness_session per test vs bare Session() + close()",
            per_test,
            bare_session,
            "s",
            f"ratio >= {_MIN_RATIO} (<= {1 / _MIN_RATIO:g}x a bare Session)",
            bare_session / per_test >= _MIN_RATIO,
            higher_is_better=False,
            note="the plugin's own cost is the gap between the two",
        ),
    ]
