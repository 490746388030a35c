"""CollisionTracker (harness.sim.collisions) on synthetic contact sets."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from harness.sim.collisions import CollisionTracker, allowed_pairs
from harness.sim.contacts import ContactSet


def contacts(rows):
    """rows: (body1, body2, depth, force, normal_x)."""
    if not rows:
        return ContactSet.empty()
    b1 = np.array([r[0] for r in rows], dtype=np.int32)
    b2 = np.array([r[1] for r in rows], dtype=np.int32)
    return ContactSet(
        geom1=b1 * 10,
        geom2=b2 * 10,
        body1=b1,
        body2=b2,
        depth=np.array([r[2] for r in rows], dtype=float),
        normal_force=np.array([r[3] for r in rows], dtype=float),
        position=np.zeros((len(rows), 3)),
        normal=np.array([[r[4], 0.0, 0.0] for r in rows], dtype=float),
    )


def reference_episodes(present, debounce):
    """(begin_step, end_step) per episode from a presence list (steps numbered from 1)."""
    episodes, begin, absent, end = [], None, 0, None
    for step, here in enumerate(present, start=1):
        if here:
            if begin is None:
                begin = step
            absent, end = 0, None
        elif begin is not None:
            if absent == 0:
                end = step
            absent += 1
            if absent >= debounce:
                episodes.append((begin, end))
                begin, absent, end = None, 0, None
    if begin is not None:
        episodes.append((begin, end if end is not None else len(present)))
    return episodes


@given(st.lists(st.booleans(), min_size=1, max_size=60), st.integers(1, 6))
def test_debounced_episodes_match_the_reference(present, debounce):
    tracker = CollisionTracker(debounce_steps=debounce)
    got = []
    for step, here in enumerate(present, start=1):
        rows = [(1, 2, 0.001, 1.0, 1.0)] if here else []
        for t in tracker.update(step, step * 10, contacts(rows)):
            if t.kind == "end":
                got.append((t.begin_step, t.end_step))
                assert t.step >= t.end_step
                assert t.duration_ns == (t.end_step - t.begin_step) * 10
    got += [(t.begin_step, t.end_step) for t in tracker.finish(len(present), len(present) * 10)]
    assert got == reference_episodes(present, debounce)


def test_pairs_are_ordered_and_normals_point_from_body1_to_body2():
    tracker = CollisionTracker()
    (begin,) = tracker.update(1, 10, contacts([(5, 3, 0.002, 4.0, 1.0)]))
    assert (begin.body1, begin.body2) == (3, 5)
    assert (begin.geom1, begin.geom2) == (30, 50)
    assert begin.normal == (-1.0, 0.0, 0.0)


def test_peaks_take_the_deepest_contact_and_the_largest_force():
    tracker = CollisionTracker()
    tracker.update(1, 10, contacts([(1, 2, 0.001, 9.0, 1.0), (1, 2, 0.004, 2.0, 1.0)]))
    tracker.update(2, 20, contacts([(1, 2, 0.003, 5.0, 1.0)]))
    (end,) = tracker.update(3, 30, contacts([]))
    assert end.penetration == 0.004
    assert end.normal_force == 9.0


def test_contacts_inside_the_margin_without_force_do_not_count():
    tracker = CollisionTracker()
    assert tracker.update(1, 10, contacts([(1, 2, -0.001, 0.0, 1.0)])) == []
    (begin,) = tracker.update(2, 20, contacts([(1, 2, -0.001, 0.5, 1.0)]))
    assert begin.penetration == 0.0


def test_allowed_pairs_classes():
    allowed = allowed_pairs(5, robot_bodies=[1, 2], self_contacts=False)
    assert not allowed[1, 2]
    assert allowed[1, 3]
    assert allowed[3, 4]
    allowed = allowed_pairs(5, robot_bodies=[1, 2], robot_vs_world_only=True, ignore=[(4, 1)])
    assert not allowed[1, 2]
    assert allowed[1, 3]
    assert not allowed[3, 4]
    assert not allowed[1, 4]
    assert not allowed[4, 1]


@given(
    st.lists(
        st.tuples(
            st.integers(0, 6),
            st.integers(0, 6),
            st.floats(-0.01, 0.01),
            st.floats(0.0, 10.0),
            st.sampled_from([1.0, -1.0]),
        ),
        min_size=1,
        max_size=120,  # covers both the plain-Python and the array grouping
    )
)
def test_grouping_keeps_the_deepest_contact_and_the_largest_force(rows):
    rows = [r for r in rows if r[0] != r[1]]
    expected = {}
    for i, (a, b, depth, force, _) in enumerate(rows):
        if not (depth >= 0.0 or force > 0.0):
            continue
        key = (min(a, b), max(a, b))
        best = expected.get(key)
        if best is None:
            expected[key] = [i, force, depth]
        else:
            if depth > best[2]:
                best[0], best[2] = i, depth
            best[1] = max(best[1], force)
    begins = CollisionTracker().update(1, 10, contacts(rows))
    assert [(t.body1, t.body2) for t in begins] == sorted(expected)
    for t in begins:
        i, force, depth = expected[(t.body1, t.body2)]
        assert t.normal_force == force
        assert t.penetration == max(depth, 0.0)
        assert t.geom1 == min(rows[i][0], rows[i][1]) * 10
