"""Shared pieces of the benchmarks: one result row, timing helpers, the table, the machine.

Every benchmark measures our code and the limit it is judged against *in the same run*
(e.g. our step loop vs a raw ``mj_step`` loop), and reports the ratio, so the figures mean
something on any machine. Each ``bench/bench_*.py`` exposes ``run(quick: bool) -> list[Row]``.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import platform
import threading
import time
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "STEP_CLIENT",
    "Row",
    "best_of",
    "format_markdown",
    "format_table",
    "machine",
    "rss_mb",
    "websockets_thread",
]


STEP_CLIENT = r"""
import json, sys, time
from websockets.sync.client import connect
url, steps = sys.argv[1], int(sys.argv[2])
with connect(url, compression=None) as ws:
    call = {"op": "call_service", "service": "/harness/step", "args": {"steps": 1}, "id": "s"}
    def run(n):
        for _ in range(n):
            ws.send(json.dumps(call))
            while json.loads(ws.recv())["op"] != "service_response":
                pass
    run(200)  # warm-up
    start = time.perf_counter()
    run(steps)
    print(time.perf_counter() - start, flush=True)
"""
"""A client program (``python -c STEP_CLIENT URL STEPS``): one ``/harness/step`` of one step at a
time over a WebSocket, 200 to warm up, then prints the seconds ``STEPS`` took."""


@dataclass(frozen=True)
class Row:
    """One figure: ``ours`` measured beside ``limit`` in the same run; ``target`` the bar to
    meet (text), ``passed`` whether it was met.

    :attr:`ratio` reads the same way for every row: the fraction of the limit's performance we
    reach (above 1: better than the limit). It is ``ours / limit`` where higher is better
    (rates) and ``limit / ours`` where lower is better (times, latencies)."""

    name: str
    ours: float
    limit: float
    unit: str
    target: str
    passed: bool
    higher_is_better: bool = True
    note: str = ""

    @property
    def ratio(self) -> float:
        """Performance relative to the limit (1.0: as good as the limit)."""
        if self.higher_is_better:
            return self.ours / self.limit if self.limit else float("nan")
        return self.limit / self.ours if self.ours else float("nan")

    def as_dict(self) -> dict[str, object]:
        """The row with its ratio, for JSON."""
        return {**asdict(self), "ratio": self.ratio}


def best_of(fn: Callable[[], object], repeats: int = 5) -> float:
    """Best wall-clock seconds of ``repeats`` calls (benchmarks only; never in tests)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


@contextlib.contextmanager
def websockets_thread(
    handler: Callable[[Any], Awaitable[None]],
) -> Iterator[tuple[int, threading.Thread]]:
    """A bare ``websockets`` asyncio server (the library the session serves with, compression
    off) serving ``handler`` on 127.0.0.1 from a thread of this process, as the session runs:
    yields its port and thread (for its CPU clock), stopped on exit. The limit of the rows
    that compare our server with the library alone."""
    from websockets.asyncio.server import serve

    ready = threading.Event()
    box: dict[str, Any] = {}

    async def main() -> None:
        async with serve(handler, "127.0.0.1", 0, compression=None) as server:
            box["port"] = server.sockets[0].getsockname()[1]
            box["loop"] = asyncio.get_running_loop()
            box["stop"] = stop = asyncio.Event()
            ready.set()
            await stop.wait()

    thread = threading.Thread(target=asyncio.run, args=(main(),), daemon=True)
    thread.start()
    ready.wait()
    try:
        yield box["port"], thread
    finally:
        box["loop"].call_soon_threadsafe(box["stop"].set)
        thread.join()


def rss_mb(pid: int | None = None) -> float:
    """Resident set size of a process (default: this one) in MiB, from ``/proc``."""
    status = Path(f"/proc/{pid or os.getpid()}/status").read_text()
    for line in status.splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def machine() -> str:
    """One line naming the machine the figures come from: CPU model, cores, memory, OS,
    Python and MuJoCo versions."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    memory = ""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                memory = f", {int(line.split()[1]) / 2**20:.0f} GiB RAM"
                break
    except OSError:
        pass
    try:
        import mujoco

        engine = f", MuJoCo {mujoco.__version__}"
    except ImportError:
        engine = ""
    return (
        f"{cpu} ({os.cpu_count()} cores{memory}), {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}{engine}"
    )


def _cells(r: Row) -> tuple[str, str, str, str, str]:
    return (
        f"{r.ours:.4g} {r.unit}",
        f"{r.limit:.4g} {r.unit}",
        f"{r.ratio:.3f}",
        r.target,
        "yes" if r.passed else "NO",
    )


def format_table(rows: list[Row]) -> str:
    """The rows as a fixed-width text table (ratio: see :attr:`Row.ratio`)."""
    header = f"{'benchmark':<56} {'ours':>16} {'limit':>16} {'ratio':>7}  {'target':<30} ok"
    lines = [header, "-" * len(header)]
    for r in rows:
        ours, limit, ratio, target, ok = _cells(r)
        lines.append(f"{r.name:<56} {ours:>16} {limit:>16} {ratio:>7}  {target:<30} {ok}")
    return "\n".join(lines)


def format_markdown(rows: list[Row]) -> str:
    """The rows as a Markdown table (for the README)."""
    lines = ["| benchmark | ours | limit | ratio | target | ok |", "|---|---:|---:|---:|---|---|"]
    for r in rows:
        ours, limit, ratio, target, ok = _cells(r)
        lines.append(f"| {r.name} | {ours} | {limit} | {ratio} | {target} | {ok} |")
    return "\n".join(lines)
