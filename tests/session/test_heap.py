"""A realtime session holds the process's heap out of full collections while it runs
(harness.session.live.heap) and gives it back at its close; other clocks leave the collector
alone."""

from __future__ import annotations

import gc

from harness.models import LoadedRobot
from harness.session import Session
from harness.session.live import heap


def test_a_realtime_session_freezes_the_heap_until_its_close(demo_position: LoadedRobot) -> None:
    assert heap.holders() == 0
    assert gc.get_freeze_count() == 0
    first = Session(demo_position, clock="realtime")
    try:
        assert heap.holders() == 1
        frozen = gc.get_freeze_count()
        assert frozen > 1000  # the imported libraries' objects, the session's own
        # what the run allocates stays collectable: a reference cycle made now is collected
        cycle: list[object] = []
        cycle.append(cycle)
        marker = id(cycle)
        del cycle
        gc.collect()
        assert all(id(o) != marker for o in gc.get_objects())
        with Session(demo_position, clock="realtime"):
            assert heap.holders() == 2
        assert heap.holders() == 1
        assert gc.get_freeze_count() > frozen // 2  # still held by the first session
    finally:
        first.close()
    assert heap.holders() == 0
    assert gc.get_freeze_count() == 0
    first.close()  # idempotent: releases once
    assert heap.holders() == 0


def test_lockstep_and_fast_sessions_leave_the_collector_alone(demo_position: LoadedRobot) -> None:
    for clock in ("lockstep", "fast"):
        with Session(demo_position, clock=clock):
            assert heap.holders() == 0
            assert gc.get_freeze_count() == 0


def test_a_release_without_a_hold_changes_nothing() -> None:
    heap.release()
    assert heap.holders() == 0
    assert gc.get_freeze_count() == 0
