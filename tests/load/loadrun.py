"""One load run against a recording Session, shared by tests/load and bench/bench_load.py.

:func:`load_run` starts a :class:`harness.Session` (demo arm, realtime clock, recording on),
runs ``loadgen.py`` against it in its own process, samples this process's RSS while the load
runs, closes the session and counts the bridge frames in the recording per client, so that
"every frame the server saw is in the recording" can be checked against what the clients
sent and received.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from harness.recording import Recording
from harness.session import Session

LOADGEN = Path(__file__).resolve().parent / "loadgen.py"


def rss_mb() -> float:
    """This process's resident set size in MiB (``/proc``)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


@dataclass(frozen=True)
class LoadResult:
    """What the clients saw (``clients``: loadgen's JSON), the recording's counts and RSS."""

    clients: dict[str, Any]
    recorded_in: dict[str, int]
    """Incoming ``publish`` frames per client topic in the recording."""
    recorded_out: dict[str, int]
    """Outgoing ``publish`` frames on each client's subscribed topic, to that client."""
    recording_complete: bool
    recording_problems: list[str]
    steps: int
    session_seconds: float
    """Wall time from the session's start to the end of the load (for steps/s)."""
    rss_start_mb: float
    rss_peak_mb: float
    rss_end_mb: float
    failure: str | None

    def mismatches(self) -> list[str]:
        """Every way the recording and the clients' counts disagree (empty: complete)."""
        out = []
        for c in self.clients["per_client"]:
            topic, listens = c["topic"], c["listens_to"]
            if self.recorded_in.get(topic, 0) != c["sent"]:
                out.append(
                    f"{topic}: sent {c['sent']}, recorded in {self.recorded_in.get(topic, 0)}"
                )
            delivered = c["received"] + c["dropped"]
            if self.recorded_out.get(topic, 0) != delivered:
                out.append(
                    f"{topic} <- {listens}: received {c['received']} + dropped {c['dropped']}, "
                    f"recorded out {self.recorded_out.get(topic, 0)}"
                )
        return out


def _count(path: Path) -> tuple[dict[str, int], dict[str, int], bool, list[str]]:
    owner: dict[int, str] = {}  # connection -> the client topic it advertised
    frames_in: Counter[str] = Counter()
    frames_out: Counter[tuple[int, str]] = Counter()
    with Recording(path) as rec:
        for f in rec.bridge_frames():
            if f.direction == 0:
                if f.op == "advertise" and f.topic.startswith("/load/"):
                    owner[f.connection] = f.topic
                elif f.op == "publish" and f.topic.startswith("/load/"):
                    frames_in[f.topic] += 1
            elif f.op == "publish" and f.topic.startswith("/load/"):
                frames_out[(f.connection, f.topic)] += 1
        complete = rec.complete
        problems = [str(p) for p in rec.problems]
    n = len(owner)
    out: dict[str, int] = {}
    for (cid, topic), count in frames_out.items():
        mine = owner.get(cid)
        if mine is not None and topic == f"/load/c{(int(mine[7:]) + 1) % n}":
            out[mine] = out.get(mine, 0) + count
    return dict(frames_in), out, complete, problems


def load_run(
    record_to: Path, *, clients: int, rate: float, seconds: float, timeout: float
) -> LoadResult:
    """Run the load against a recording Session; see the module docstring."""
    start_rss = peak = rss_mb()
    with Session("demo", clock="realtime", record_to=record_to) as session:
        started = time.perf_counter()
        proc = subprocess.Popen(
            [
                sys.executable,
                str(LOADGEN),
                session.url,
                "--clients",
                str(clients),
                "--rate",
                str(rate),
                "--seconds",
                str(seconds),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        waited = 0.0
        while True:
            try:
                out, err = proc.communicate(timeout=0.25)
                break
            except subprocess.TimeoutExpired as exc:
                waited += 0.25
                peak = max(peak, rss_mb())
                if waited > timeout:
                    proc.kill()
                    out, err = proc.communicate()
                    raise RuntimeError(
                        f"load generator did not finish in {timeout} s: {err[-2000:]}"
                    ) from exc
        if proc.returncode != 0:
            raise RuntimeError(f"load generator failed ({proc.returncode}): {err[-2000:]}")
        peak = max(peak, rss_mb())
        steps = session.step_index
        session_seconds = time.perf_counter() - started
        failure = None if session.failure is None else str(session.failure)
    end_rss = rss_mb()
    recorded_in, recorded_out, complete, problems = _count(record_to)
    return LoadResult(
        clients=json.loads(out),
        recorded_in=recorded_in,
        recorded_out=recorded_out,
        recording_complete=complete,
        recording_problems=problems,
        steps=steps,
        session_seconds=session_seconds,
        rss_start_mb=start_rss,
        rss_peak_mb=peak,
        rss_end_mb=end_rss,
        failure=failure,
    )
