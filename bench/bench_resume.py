"""Resume: seek time to step k against the parent's replay throughput.

A lockstep session of the demo arm (position servos, every step's state recorded, a Python
command every 500 steps) is recorded; then it is resumed at its last step
(:func:`harness.resume.seek`: rebuild the robot from the recording, re-run every recorded
input through a fresh session core, check every state against the recording, record the child)
and, as the limit, replayed at ``--level full`` (:func:`harness.replay.pipeline.replay_pipeline`:
the same core, the same inputs, every frame, input and state compared). Both are timed from
opening the file to the end, best of a few rounds. Target: the seek reaches >= 0.8 of the
replay's throughput (it is a replay that keeps its core).

Also reported: the seek that records the child recording's prefix (the run up to k, re-derived
and written, as a live run records it), and the seconds a seek to minute 10 of a 1 kHz run
would take (no keyframes: the seek re-runs every step before the fork).
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

from common import Row

from harness import Session
from harness.replay.pipeline import replay_pipeline
from harness.resume import close_fork, seek


def _record(path: Path, steps: int) -> None:
    with Session("demo", clock="lockstep", record_to=path) as session:
        for k in range(0, steps, 500):
            sign = 1.0 if (k // 500) % 2 else -1.0
            session.set_positions({"joint1": 0.3 * sign, "joint2": 0.1 * sign})
            session.step(min(500, steps - k))


def run(quick: bool) -> list[Row]:
    steps = 4_000 if quick else 20_000
    rounds = 2 if quick else 3
    with tempfile.TemporaryDirectory() as tmp:
        parent = Path(tmp) / "parent.mcap"
        _record(parent, steps)
        best_seek = best_replay = best_bare = math.inf
        for i in range(rounds):  # interleaved: the machine is shared and noisy
            start = time.perf_counter()
            fork = seek(parent, step=steps, record_to=Path(tmp) / f"child{i}.mcap")
            best_seek = min(best_seek, time.perf_counter() - start)
            assert fork.core.sim.step_index == steps
            assert fork.states_checked == steps + 1
            close_fork(fork)
            start = time.perf_counter()
            fork = seek(parent, step=steps)
            best_bare = min(best_bare, time.perf_counter() - start)
            close_fork(fork)
            start = time.perf_counter()
            report = replay_pipeline(parent)
            best_replay = min(best_replay, time.perf_counter() - start)
            assert report.reproduced, report.format()
    seek_rate, replay_rate = steps / best_bare, steps / best_replay
    child_rate = steps / best_seek
    minute_10 = 600_000
    return [
        Row(
            "resume: seek to step k vs replay --level full",
            seek_rate,
            replay_rate,
            "st/s",
            ">= 0.8 of the replay's throughput",
            seek_rate / replay_rate >= 0.8,
            note=f"demo arm, {steps} steps, every state checked against the recording",
        ),
        Row(
            "resume: seek recording the child's prefix vs replay",
            child_rate,
            replay_rate,
            "st/s",
            "(reported: the child re-records every step before k)",
            True,
        ),
        Row(
            "resume: seconds to seek to minute 10 at 1 kHz",
            minute_10 / seek_rate,
            minute_10 / replay_rate,
            "s",
            "(reported: no keyframes, the seek re-runs every step)",
            True,
            higher_is_better=False,
            note="extrapolated",
        ),
    ]


if __name__ == "__main__":
    from common import format_table

    print(format_table(run(quick="--quick" in sys.argv)))
