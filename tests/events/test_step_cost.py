"""The per-step shortcuts of the loggers (issue 36's speed) give what the plain computation
gives: the collision tracker against a reference over random step sequences (pairs appearing,
vanishing and reordering, peaks across steps), normal forces against ``mj_contactForce``, the
support cache against fresh classification, the clearance broad phase against exhaustive
measurement, and the core's quiet periodic topics still counted."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.events import ClearanceLogger, StepContext
from harness.events.support import SupportClassifier
from harness.sim.collisions import CollisionTracker
from harness.sim.contacts import ContactSet, extract_contacts, normal_forces

from .test_tracker import contacts

Row = tuple[int, int, float, float, float]


def reference(steps: list[list[Row]], debounce: int) -> list[tuple[object, ...]]:
    """The tracker's documented semantics, computed plainly, one step at a time."""
    opened: dict[tuple[int, int], dict[str, float]] = {}
    out: list[tuple[object, ...]] = []

    def event(kind: str, key: tuple[int, int], step: int, ep: dict[str, float]) -> tuple:
        pen = max(ep["pen"], 0.0)
        return (kind, key, step, ep["begin"], ep["end"], ep["force"], pen, ep["normal"])

    for k, rows in enumerate(steps, start=1):
        seen: dict[tuple[int, int], list[float]] = {}
        for i, (a, b, d, f, _) in enumerate(rows):
            if not (d >= 0.0 or f > 0.0):
                continue
            key = (min(a, b), max(a, b))
            if key not in seen:
                seen[key] = [i, f]
                continue
            if d > rows[int(seen[key][0])][2]:
                seen[key][0] = i
            seen[key][1] = max(seen[key][1], f)
        ends = []
        for key in sorted(set(opened) - set(seen)):
            ep = opened[key]
            if ep["absent"] == 0:
                ep["end"] = k
            ep["absent"] += 1
            if ep["absent"] >= debounce:
                del opened[key]
                ends.append(event("end", key, k, ep))
        begins = []
        for key in sorted(seen):
            index, force = int(seen[key][0]), seen[key][1]
            fresh = key not in opened
            if fresh:
                opened[key] = {"begin": k, "absent": 0, "end": -1, "force": 0.0, "pen": -math.inf}
                opened[key]["normal"] = 0.0
            ep = opened[key]
            ep["absent"], ep["end"] = 0, -1
            ep["force"] = max(ep["force"], force)
            a, _, d, _, nx = rows[index]
            if d > ep["pen"]:
                ep["pen"] = d
                ep["normal"] = nx if a == key[0] else -nx
            if fresh:
                begins.append(event("begin", key, k, ep))
        out += ends + begins
    return out


def tracked(steps: list[list[Row]], debounce: int) -> list[tuple[object, ...]]:
    tracker = CollisionTracker(debounce_steps=debounce)
    out: list[tuple[object, ...]] = []
    for k, rows in enumerate(steps, start=1):
        for t in tracker.update(k, k * 10, contacts(rows)):
            key = (t.body1, t.body2)
            peaks = (t.normal_force, t.penetration, t.normal[0])
            out.append((t.kind, key, t.step, t.begin_step, t.end_step, *peaks))
    return out


_row = st.tuples(
    st.integers(1, 3),
    st.integers(4, 6) | st.integers(1, 3),
    st.sampled_from([-0.002, 0.0, 0.001, 0.003]),
    st.sampled_from([0.0, 1.0, 2.5, 9.0]),
    st.sampled_from([-1.0, 0.5, 1.0]),
).filter(lambda r: r[0] != r[1])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(_row, max_size=6), max_size=12), st.integers(1, 3))
def test_tracker_matches_the_reference_step_by_step(steps: list[list[Row]], debounce: int) -> None:
    """Pairs appearing and vanishing, the same pairs reordered or with their bodies swapped, a
    new pair beside a persisting one, peaks of force and depth carried across steps."""
    assert tracked(steps, debounce) == reference(steps, debounce)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.lists(_row, min_size=49, max_size=60), min_size=1, max_size=4))
def test_tracker_array_path_matches_the_reference(steps: list[list[Row]]) -> None:
    """More than 48 contacts in a step: the array grouping, the same results."""
    assert tracked(steps, 2) == reference(steps, 2)


def test_reordered_contacts_of_the_same_pairs_are_no_transition() -> None:
    tracker = CollisionTracker()
    first = tracker.update(1, 10, contacts([(1, 2, 0.001, 1.0, 1.0), (3, 4, 0.001, 1.0, 1.0)]))
    assert [t.kind for t in first] == ["begin", "begin"]
    assert tracker.update(2, 20, contacts([(4, 3, 0.002, 5.0, 1.0), (2, 1, 0.0, 7.0, 1.0)])) == []
    (end,) = tracker.update(3, 30, contacts([(2, 1, 0.0, 1.0, 1.0)]))
    assert (end.body1, end.body2, end.normal_force, end.penetration) == (3, 4, 5.0, 0.002)
    assert end.normal == (-1.0, 0.0, 0.0)  # the deepest contact had its bodies swapped


SCENE = """
<mujoco><option cone="{cone}" timestep="0.002"/><worldbody>
<geom name="floor" type="plane" size="5 5 0.1"/>
{bodies}
</worldbody></mujoco>
"""


def _boxes(n: int, condim: str) -> str:
    return "".join(
        f'<body pos="{(i % 5) * 0.3} {(i // 5) * 0.3} 0.049"><freejoint/>'
        f'<geom type="box" size="0.05 0.05 0.05" condim="{condim}"/></body>'
        for i in range(n)
    )


@pytest.mark.parametrize("boxes", [1, 6])
@pytest.mark.parametrize(
    ("cone", "condims"),
    [
        ("pyramidal", "3"),
        ("pyramidal", "4"),
        ("pyramidal", "6"),
        ("elliptic", "3"),
        ("pyramidal", "1"),
    ],
)
def test_normal_forces_are_mj_contact_force_bit_for_bit(
    cone: str, condims: str, boxes: int
) -> None:
    """Each force is ``mj_contactForce(...)[0]``, same bits (condim 1 and excluded rows: one
    by one; the others: from ``efc_force`` in MuJoCo's order of summation)."""
    model = mujoco.MjModel.from_xml_string(SCENE.format(cone=cone, bodies=_boxes(boxes, condims)))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 100)
    n = int(data.ncon)
    assert n > 16 if boxes > 1 else 0 < n <= 16  # the array path; one by one up to 16
    f6 = np.zeros(6)
    expected = []
    for i in range(n):
        mujoco.mj_contactForce(model, data, i, f6)
        expected.append(f6[0])
    got = normal_forces(model, data, data.contact.efc_address)
    assert np.array(expected).tobytes() == got.tobytes()
    assert extract_contacts(model, data).normal_force.tobytes() == got.tobytes()


def test_support_cache_follows_each_steps_normals() -> None:
    """The same geoms in two steps with the normal turned over: support follows the normal
    (what depends on the geoms alone is kept; what depends on the step is not); other geoms:
    classified afresh (a wheel on a block is support, the base on it is not)."""
    xml = (
        '<mujoco><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>'
        '<geom name="block" type="box" size="0.1 0.1 0.1" pos="2 0 0.1"/>'
        '<body name="base" pos="0 0 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.05"/>'
        '<body name="wheel_left"><joint type="hinge" axis="0 1 0"/>'
        '<geom type="cylinder" size="0.03 0.01"/></body></body></worldbody></mujoco>'
    )
    model = mujoco.MjModel.from_xml_string(xml)
    wheel = model.body("wheel_left").id
    classifier = SupportClassifier(model, {model.body("base").id, wheel})
    wheel_geom = int(model.body_geomadr[wheel])
    classifier.learn_floors(ContactSet.empty())

    base, base_geom = model.body("base").id, int(model.body_geomadr[model.body("base").id])
    block = model.geom("block").id

    def one(nz: float, other: int = 0, mine: int = wheel_geom, body: int = wheel) -> ContactSet:
        return ContactSet(
            geom1=np.array([other], dtype=np.int32),
            geom2=np.array([mine], dtype=np.int32),
            body1=np.array([0], dtype=np.int32),
            body2=np.array([body], dtype=np.int32),
            depth=np.zeros(1),
            normal_force=np.ones(1),
            position=np.zeros((1, 3)),
            normal=np.array([[0.0, 0.0, nz]]),
        )

    assert classifier.support(one(1.0)).tolist() == [True]
    assert classifier.support(one(-1.0)).tolist() == [False]
    assert classifier.support(one(1.0)).tolist() == [True]
    assert classifier.support(one(1.0, block, base_geom, base)).tolist() == [False]
    assert classifier.support(one(1.0, block)).tolist() == [True]
    assert classifier.support(one(1.0, block, base_geom, base)).tolist() == [False]


ARM = """
<mujoco><option timestep="0.002"/><worldbody>
<geom name="floor" type="plane" size="5 5 0.1"/>
<geom name="table" type="box" size="0.4 0.3 0.02" pos="0 0 0.4"/>
<geom name="post" type="sphere" size="0.03" pos="0.35 0.1 0.55"/>
<body name="link1" pos="0 0 0.45"><joint name="j1" type="hinge" axis="0 0 1" damping="0.1"/>
  <geom name="upper" type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.02"/>
  <body name="link2" pos="0.2 0 0.1"><joint name="j2" type="hinge" axis="0 1 0" damping="0.1"/>
    <geom name="lower" type="box" size="0.1 0.015 0.015" pos="0.1 0 0"/>
    <geom name="tip" type="cylinder" size="0.02 0.02" pos="0.2 0 0"/></body></body>
<body name="ball" pos="-0.2 -0.2 0.6"><freejoint/>
  <geom name="ball" type="sphere" size="0.04"/></body>
</worldbody><actuator><motor joint="j1" gear="1"/><motor joint="j2" gear="1"/></actuator></mujoco>
"""


def test_clearance_broad_phase_is_a_lower_bound_and_keeps_the_exhaustive_minimum() -> None:
    """Every step: the broad phase's positive bound of a pair is at most its exact distance,
    and the logger's running minimum is the minimum of every pair measured exactly at every
    step (the arm swings through the post and the table: overlaps too)."""
    model = mujoco.MjModel.from_xml_string(ARM)
    data = mujoco.MjData(model)
    logger = ClearanceLogger(model, robot_bodies=["link1", "link2"], distmax=1.0)
    exhaustive = math.inf
    rng = np.random.default_rng(1)
    for k in range(1, 401):
        data.ctrl[:] = rng.uniform(-0.5, 0.5, 2)
        mujoco.mj_step(model, data)
        ctx = StepContext(k, k * 2_000_000, model, data, extract_contacts(model, data), "arm")
        logger.observe(ctx)
        exact = [
            mujoco.mj_geomDistance(model, data, int(a), int(b), 10.0, None)
            for a, b in logger._pairs
        ]
        bound = logger._bounds.lower(data.geom_xpos)
        positive = bound > 0.0  # the others may overlap: always measured
        assert (bound[positive] <= np.array(exact)[positive] + 1e-12).all(), k
        exhaustive = min(exhaustive, min(exact))
        assert logger.minimum.distance == pytest.approx(min(exhaustive, 1.0), abs=1e-12), k
    assert logger.minimum.distance < 1.0  # something came within distmax


def test_quiet_periodic_topics_are_counted_without_a_recorder() -> None:
    """Nothing records and nobody subscribes: /clock, /joint_states and /tf are not built but
    still counted (``/harness/step``'s ``until_topic`` waits on the counts)."""
    from harness.models import load_robot
    from harness.session.core import CoreOptions, SessionCore

    core = SessionCore(load_robot("demo"), CoreOptions(clock="lockstep"))
    core.start()
    core.publish_initial()
    for _ in range(20):
        core.advance()
    counts = core.publish_counts
    js = core.robots[0].topics.joint_states
    assert counts.count("/clock") > 0
    assert counts.count(js) > 0
    assert counts.count("/tf") > 0
    core.finish()


PUSHED = """
name: pushed
environment: {map: table}
robots:
  - robot: demo
    name: arm
    modes:
      - {type: JointController, mode: effort}
duration: 0.6
seed: 0
clock: {mode: lockstep}
recording: {enabled: false}
script:
  - {at: 0.0, efforts: {joint4: 80.0, joint6: -12.0, joint2: 80.0, finger_joint1: 60.0}}
  - {at: 0.3, efforts: {joint4: -80.0, joint6: 12.0, joint2: -80.0}}
"""


class _Fold:
    """Every step's ``max(lower - q, q - upper)`` folded with a maximum from 0, per joint."""

    name = "fold"
    period_ns = 0

    def __init__(self, session: object) -> None:
        sim = session.sim  # type: ignore[attr-defined]
        model = sim.model
        ids = [model.joint(j).id for j in sim.joint_names]
        self.qadr = np.array([model.jnt_qposadr[i] for i in ids])
        ranges = np.asarray(model.jnt_range)[ids]
        limited = np.array([bool(model.jnt_limited[i]) for i in ids])
        self.lower = np.where(limited, ranges[:, 0], -np.inf)
        self.upper = np.where(limited, ranges[:, 1], np.inf)
        self.excess = np.zeros(len(ids))

    def observe(self, ctx: StepContext) -> list[object]:
        q = ctx.data.qpos[self.qadr]
        np.maximum(self.excess, np.maximum(self.lower - q, q - self.upper), out=self.excess)
        return []

    def finish(self, ctx: StepContext) -> list[object]:
        return []


def test_runner_max_excess_is_the_per_step_maximum(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The scenario runner's max excess per joint (from the range each joint reached) is the
    maximum of every step's excess, bit for bit, with joints driven past their limits."""
    import dataclasses

    from harness.scenario import iteration_specs, load_run_file, session_iteration_runner

    file = tmp_path / "pushed.yaml"
    file.write_text(PUSHED, encoding="utf-8")
    spec = iteration_specs(load_run_file(file), tmp_path)[0]
    folds: list[_Fold] = []

    def fold(session: object) -> _Fold:
        folds.append(_Fold(session))
        return folds[-1]

    runner = dataclasses.replace(session_iteration_runner(), watchers=(fold,))
    result = runner(spec)
    got = [j.max_excess for j in result.joint_limits]
    assert got == folds[0].excess.tolist()
    assert sum(e > 0.01 for e in got) >= 3  # several joints well past a limit
