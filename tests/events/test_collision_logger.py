"""CollisionLogger on scripted MuJoCo scenes with known answers."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.events import (
    CollectingSink,
    CollisionBegin,
    CollisionEnd,
    CollisionLogger,
    EventHub,
    LoggerConfigError,
    NearMiss,
)

DT_NS = 2_000_000


def pairs(events):
    return {(e.body1, e.body2) for e in events if isinstance(e, (CollisionBegin, CollisionEnd))}


def run_logger(scene, model, script, steps, **options):
    sink = CollectingSink()
    hub = EventHub([CollisionLogger(model, **options)], [sink])
    digest = scene.run(model, hub, steps, script)
    return sink, digest


def test_pusher_touches_block_once(scene, pusher):
    model = scene.model("workcell.xml")
    sink, _ = run_logger(
        scene,
        model,
        pusher(205),
        260,
        robot_root="pusher",
        robot_vs_world_only=True,
        debounce_steps=3,
    )
    begins = sink.of_kind(CollisionBegin)
    ends = sink.of_kind(CollisionEnd)
    assert len(begins) == 1
    assert len(ends) == 1
    begin, end = begins[0], ends[0]
    assert (begin.body1, begin.body2) == ("pusher", "block")
    assert (begin.geom1, begin.geom2) == ("pusher_ball", "block_box")
    # x_k > 0.2 (sphere surface past the block face) for k = 200..210, i.e. steps 201..211.
    assert begin.step == 201
    assert begin.sim_time_ns == 201 * DT_NS
    assert (end.begin_step, end.end_step) == (201, 212)
    assert end.step == 212 + 3 - 1  # emitted once the debounce window passed
    assert end.duration_ns == 11 * DT_NS
    assert not end.at_finish
    assert end.penetration == pytest.approx(0.0055, abs=1e-9)  # peak at k = 205
    assert begin.penetration == pytest.approx(0.0005, abs=1e-9)
    assert end.normal == pytest.approx((1.0, 0.0, 0.0), abs=1e-9)  # from pusher to block
    assert end.position[0] == pytest.approx(0.25 + 0.0055 / 2, abs=1e-9)  # mid-penetration
    assert end.normal_force > begin.normal_force > 0.0


def test_peak_force_matches_an_independent_reading(scene, pusher):
    model = scene.model("workcell.xml")
    seen: list[float] = []
    base = pusher(205)
    f6 = np.zeros(6)
    state = {"data": None}

    def script(k, data):
        # read the previous step's pusher-block force with our own loop over d.contact
        if state["data"] is not None:
            for i in range(data.ncon):
                bodies = {model.geom_bodyid[g] for g in data.contact.geom[i]}
                if bodies == {1, 2}:
                    mujoco.mj_contactForce(model, data, i, f6)
                    seen.append(float(f6[0]))
        state["data"] = data
        base(k, data)

    sink, _ = run_logger(scene, model, script, 260, robot_root="pusher", robot_vs_world_only=True)
    (end,) = sink.of_kind(CollisionEnd)
    assert end.normal_force == max(seen)


def test_box_resting_on_table_one_begin_no_chatter(scene):
    model = scene.model("bouncing_box.xml")
    raw, _ = run_logger(scene, model, None, 1500, debounce_steps=1)
    assert len(raw.of_kind(CollisionBegin)) > 1, "the scene must chatter without debounce"
    sink, _ = run_logger(scene, model, None, 1500, debounce_steps=10)
    begins = sink.of_kind(CollisionBegin)
    ends = sink.of_kind(CollisionEnd)
    assert [(b.body1, b.body2) for b in begins] == [("table", "box")]
    assert len(ends) == 1
    assert ends[0].at_finish
    assert ends[0].end_step == 1500
    assert ends[0].duration_ns == (1500 - begins[0].step) * DT_NS


def fold(k, data):
    angle = min(k / 300, 1.0) * 2.6
    data.qpos[:] = (0.0, angle, angle)
    data.qvel[:] = 0.0


@pytest.mark.parametrize("self_contacts", [True, False])
def test_self_contacts_reported_or_filtered(scene, self_contacts):
    model = scene.model("folding_arm.xml")
    sink, _ = run_logger(scene, model, fold, 400, robot_root="base", self_contacts=self_contacts)
    found = pairs(sink.events)
    if self_contacts:
        assert found == {("link1", "link3")}
        (begin,) = sink.of_kind(CollisionBegin)
        assert begin.geom1 == "link1_geom"
        assert begin.geom2 == "link3_geom"
    else:
        assert found == set()


def test_filters_on_the_workcell(scene, pusher):
    model = scene.model("workcell.xml")
    script = pusher(205)
    everything, _ = run_logger(scene, model, script, 300, robot_root="pusher")
    assert pairs(everything.events) == {("pusher", "block"), ("table", "crate")}
    robot_only, _ = run_logger(
        scene, model, script, 300, robot_root="pusher", robot_vs_world_only=True
    )
    assert pairs(robot_only.events) == {("pusher", "block")}
    ignored, _ = run_logger(scene, model, script, 300, ignore=[("block", "pusher")])
    assert pairs(ignored.events) == {("table", "crate")}
    # The crate's corner contacts carry ~0.5 N each; the pusher reaches ~14 N.
    strong, _ = run_logger(scene, model, script, 300, min_force=5.0)
    assert pairs(strong.events) == {("pusher", "block")}
    (begin,) = strong.of_kind(CollisionBegin)
    assert begin.step > 201
    assert begin.normal_force >= 5.0


def test_near_miss_reported_without_changing_physics(scene, pusher):
    model = scene.model("workcell.xml")
    script = pusher(196)  # closest x = 0.1965: 3.5 mm short of the block
    plain, digest_plain = run_logger(scene, model, script, 300, robot_root="pusher")
    near, digest_near = run_logger(
        scene, model, script, 300, robot_root="pusher", near_miss_distance=0.01
    )
    assert digest_near == digest_plain
    assert pairs(plain.events) == pairs(near.events) == {("table", "crate")}
    misses = near.of_kind(NearMiss)
    assert [(m.body1, m.body2) for m in misses] == [("pusher", "block")]
    (miss,) = misses
    assert miss.distance == pytest.approx(0.0035, abs=1e-9)
    assert miss.closest_step == 197
    assert miss.normal == pytest.approx((1.0, 0.0, 0.0), abs=1e-9)
    # within 1 cm: sphere surface x = x_k + 0.05 > 0.24, i.e. x_k > 0.19: k = 190..202
    assert (miss.begin_step, miss.end_step) == (191, 204)


def test_touching_approach_is_a_collision_not_a_near_miss(scene, pusher):
    model = scene.model("workcell.xml")
    sink, _ = run_logger(
        scene,
        model,
        pusher(205),
        300,
        robot_root="pusher",
        robot_vs_world_only=True,
        near_miss_distance=0.01,
    )
    assert sink.of_kind(NearMiss) == []
    assert len(sink.of_kind(CollisionBegin)) == 1


def test_bad_configuration_names_the_key(scene):
    model = scene.model("workcell.xml")
    with pytest.raises(LoggerConfigError, match=r"ignore\[1\].*'nope'"):
        CollisionLogger(model, ignore=[("pusher", "block"), ("nope", "block")])
    with pytest.raises(LoggerConfigError, match=r"robot_root.*'arm'"):
        CollisionLogger(model, robot_root="arm")
    with pytest.raises(LoggerConfigError, match="robot_vs_world_only"):
        CollisionLogger(model, robot_vs_world_only=True)
    with pytest.raises(LoggerConfigError, match="debounce_steps"):
        CollisionLogger(model, debounce_steps=0)
