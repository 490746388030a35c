"""Shared pieces of the benchmarks: one result row, timing helpers, the table.

Every benchmark measures our code and the limit it is judged against *in the same run*
(e.g. our step loop vs a raw ``mj_step`` loop), and reports the ratio, so the figures mean
something on any machine. Each ``bench/bench_*.py`` exposes ``run(quick: bool) -> list[Row]``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Row:
    """One figure: ``ours`` measured beside ``limit``; ``ratio`` is ours/limit (or the
    inverse where lower is better, see ``higher_is_better``); ``target`` the bar to meet."""

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
        if self.limit == 0:
            return float("nan")
        return self.ours / self.limit

    def as_dict(self) -> dict[str, object]:
        return {**asdict(self), "ratio": self.ratio}


def best_of(fn: Callable[[], object], repeats: int = 5) -> float:
    """Best wall-clock seconds of ``repeats`` calls (benchmarks only; never in tests)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def format_table(rows: list[Row]) -> str:
    header = f"{'benchmark':<52} {'ours':>14} {'limit':>14} {'ratio':>7}  {'target':<18} ok"
    lines = [header, "-" * len(header)]
    for r in rows:
        lines.append(
            f"{r.name:<52} {r.ours:>10.4g} {r.unit:<3} {r.limit:>10.4g} {r.unit:<3} "
            f"{r.ratio:>7.3f}  {r.target:<18} {'yes' if r.passed else 'NO'}"
        )
    return "\n".join(lines)
