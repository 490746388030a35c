"""The realtime clock's pacing (harness.session.live.pacing), sans I/O: wall times given, not
read."""

from __future__ import annotations

import pytest

from harness.session.live.pacing import BEHIND_S, frames_until, pace

DT_NS = 2_000_000  # 2 ms steps


def test_a_new_clock_anchors_at_the_current_step_and_waits_one_period_per_step():
    delay, anchor = pace(None, 100.0, 7, DT_NS, 1.0)
    assert anchor == (100.0, 7)
    assert delay == 0.0  # the anchored step is due now
    # three steps later, 1 ms of wall time gone: 6 ms - 1 ms to wait
    delay, anchor = pace(anchor, 100.001, 10, DT_NS, 1.0)
    assert anchor == (100.0, 7)
    assert delay == pytest.approx(0.005)
    # rate 2: half the wall time per step
    delay, _ = pace((100.0, 7), 100.001, 10, DT_NS, 2.0)
    assert delay == pytest.approx(0.002)


def test_a_clock_slightly_behind_keeps_its_anchor_and_one_far_behind_moves_it():
    slightly = 100.0 + 0.006 + BEHIND_S / 2  # step 10 was due at 100.006
    delay, anchor = pace((100.0, 7), slightly, 10, DT_NS, 1.0)
    assert (delay, anchor) == (0.0, (100.0, 7))  # runs at once, catching up
    far = 100.0 + 0.006 + BEHIND_S * 2
    delay, anchor = pace((100.0, 7), far, 10, DT_NS, 1.0)
    assert (delay, anchor) == (0.0, (far, 10))  # re-anchored: no burst


def test_frames_wait_until_the_next_step_is_due_less_a_quarter_step():
    period = DT_NS / 1e9
    # no anchor: one period from now
    assert frames_until(None, 50.0, 3, DT_NS, 1.0) == pytest.approx(50.0 + period)
    # on time: step 4 due at 50.008, frames until a quarter period before it
    assert frames_until((50.0, 0), 50.0, 3, DT_NS, 1.0) == pytest.approx(
        50.0 + 4 * period - period / 4
    )
    # behind: still one period of frames (frames and clock share the time)
    assert frames_until((50.0, 0), 51.0, 3, DT_NS, 1.0) == pytest.approx(51.0 + period)


def test_input_read_while_the_clock_waits_applies_until_a_quarter_step_before_the_next():
    from harness.session.live.pacing import waiting_until

    period = DT_NS / 1e9
    assert waiting_until(None, 3, DT_NS, 1.0) is None  # no anchor: the boundary decides
    # anchored at step 0 at 50.0: step 4 due at 50.008, input until a quarter step before
    assert waiting_until((50.0, 0), 3, DT_NS, 1.0) == pytest.approx(50.0 + 4 * period - period / 4)
    # rate 0.5: twice the wall time per step
    assert waiting_until((50.0, 0), 3, DT_NS, 0.5) == pytest.approx(
        50.0 + 4 * 2 * period - period / 2
    )
