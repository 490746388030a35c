"""The loggers behind harness.sim.Simulation: StepContext.of(sim, robot) from an observer."""

from __future__ import annotations

from harness.events import (
    CollectingSink,
    CollisionBegin,
    CollisionEnd,
    CollisionLogger,
    EventHub,
    JointLogger,
    JointSample,
    StepContext,
)
from harness.sim.simulation import Simulation


def test_observer_feeds_the_hub(scene):
    model = scene.model("workcell.xml")
    sim = Simulation.from_model(model, control={"slide": "kinematic"}, keyframe=None)
    sink = CollectingSink()
    hub = EventHub(
        [
            CollisionLogger(sim.model, robot_root="pusher", robot_vs_world_only=True),
            JointLogger(sim.model, joints=["slide"], rate_hz=100),
        ],
        [sink],
    )
    sim.add_observer(lambda s: hub.observe(StepContext.of(s, "pusher")))
    for k in range(300):
        sim.set_positions({"slide": 0.0005 + 0.001 * min(k, 410 - k)})
        sim.step()
    hub.finish(StepContext.of(sim, "pusher"))
    (begin,) = sink.of_kind(CollisionBegin)
    (end,) = sink.of_kind(CollisionEnd)
    assert (begin.body1, begin.body2, begin.robot) == ("pusher", "block", "pusher")
    assert (end.begin_step, end.end_step) == (201, 212)
    samples = sink.of_kind(JointSample)
    assert len(samples) == 1 + 600_000_000 // 10_000_000  # 0.6 s at 100 Hz, both ends
    assert all(s.sim_time_ns % 10_000_000 == 0 for s in samples[1:])
