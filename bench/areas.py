"""Where a profiled thread's time goes, by area of the code (own time of every function summed
per area), for the benchmarks that explain a ratio (bench_session, bench_load).

The areas follow the package layout: a function belongs to the first area whose pattern
appears in its file name (or, for built-ins, in its name).
"""

from __future__ import annotations

import cProfile
import pstats

__all__ = ["by_area", "format_areas"]

_AREAS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("idle: waiting for the sockets (epoll)", ("poll' of 'select.epoll",)),
    ("socket syscalls (send/recv)", ("'send' of '_socket", "'recv' of '_socket")),
    ("MuJoCo step (mj_step and friends)", ("mujoco._functions",)),
    ("harness/sim (inputs, checks, reads)", ("harness/sim/",)),
    ("controllers (harness/controllers, session/control.py)", ("harness/controllers/",
                                                              "session/control.py")),
    ("recording (harness/recording)", ("harness/recording/",)),
    ("rosbridge protocol + conversion", ("rosbridge/protocol.py", "rosbridge/topics.py",
                                         "rosbridge/outgoing.py", "rosbridge/convert.py",
                                         "rosbridge/graph.py", "rosbridge/types.py",
                                         "rosbridge/deadlines.py")),
    ("rosbridge server (server.py)", ("rosbridge/server.py", "rosbridge/sending.py",
                                      "rosbridge/connection.py")),
    ("websockets library", ("site-packages/websockets/",)),
    ("session core (harness/session)", ("harness/session/", "harness/events/")),
    ("json (stdlib)", ("/json/",)),
    ("asyncio event loop", ("/asyncio/", "selectors.py")),
)  # fmt: skip


def by_area(profile: cProfile.Profile) -> list[tuple[str, float, float]]:
    """``(area, seconds, share of the total)`` for every area with time, largest first
    (``other`` last)."""
    stats = pstats.Stats(profile)
    totals: dict[str, float] = {}
    for (filename, _line, name), row in stats.stats.items():  # type: ignore[attr-defined]
        where = f"{filename}:{name}"
        area = next((a for a, keys in _AREAS if any(k in where for k in keys)), "other")
        totals[area] = totals.get(area, 0.0) + row[2]
    total = sum(totals.values()) or 1.0
    ordered = sorted(((a, t) for a, t in totals.items() if a != "other"), key=lambda x: -x[1])
    ordered.append(("other", totals.get("other", 0.0)))
    return [(a, t, t / total) for a, t in ordered]


def format_areas(profile: cProfile.Profile, per: int = 0, unit: str = "") -> str:
    """The areas as lines ``share  seconds  area`` (with ``per``: also microseconds per
    ``unit``)."""
    lines = []
    for area, seconds, share in by_area(profile):
        each = f"  {seconds / per * 1e6:7.1f} us/{unit}" if per else ""
        lines.append(f"  {share:6.1%} {seconds:8.3f} s{each}  {area}")
    return "\n".join(lines)
