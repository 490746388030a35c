"""The ``tracking_error`` margin (computed with arrays) is the plain maximum of
|position - command| over the commanded samples, also where commands are NaN (none yet) and
where a position is NaN (a run that blew up: the plain ``max`` decides)."""

from __future__ import annotations

import math
import random

import pytest

from harness.explore.episode import margins_of
from harness.scenario import IterationResult, JointTrace, Traces


def _plain(traces: tuple[JointTrace, ...]) -> float:
    errors = [
        abs(p - c)
        for t in traces
        if t.command is not None
        for p, c in zip(t.position, t.command, strict=True)
        if not math.isnan(c)
    ]
    return max(errors, default=0.0)


def _result(traces: tuple[JointTrace, ...]) -> IterationResult:
    time = tuple(float(i) for i in range(len(traces[0].position))) if traces else ()
    return IterationResult("s", 1, (), 0.0, 0, traces=Traces(time, traces))


@pytest.mark.parametrize("seed", range(6))
def test_tracking_error_is_the_plain_maximum(seed: int) -> None:
    rng = random.Random(seed)
    traces = []
    for j in range(rng.randint(0, 4)):
        n = 50
        position = [rng.uniform(-2, 2) for _ in range(n)]
        command = [rng.uniform(-2, 2) if rng.random() > 0.3 else math.nan for _ in range(n)]
        if seed >= 4 and j == 1:
            position[rng.randrange(n)] = math.nan  # a run that blew up
        traces.append(
            JointTrace(f"j{j}", tuple(position), (0.0,) * n, None if j == 2 else tuple(command))
        )
    expected = _plain(tuple(traces))
    got = margins_of(_result(tuple(traces)), None, ())["tracking_error"]
    assert type(got) is float
    assert got == expected or (math.isnan(got) and math.isnan(expected))
