"""JointLogger at a sim-time rate and JointLimitLogger on the folding arm."""

from __future__ import annotations

import math

import mujoco
import pytest

from harness.events import (
    CollectingSink,
    EventHub,
    JointLimitLogger,
    JointLimitViolation,
    JointLogger,
    JointSample,
    LoggerConfigError,
    VelocityLimitExceeded,
    velocity_limits,
)
from harness.models import Joint, JointLimits, Pose, RobotModel

DT_NS = 2_000_000


def swing(k, data):
    data.qpos[:] = (0.001 * k, 0.5 * math.sin(0.01 * k), 0.0)
    data.qvel[:] = 0.0


@pytest.mark.parametrize(
    ("rate_hz", "period_ns"), [(50.0, 20_000_000), (30.0, 33_333_333), (1.0, 1_000_000_000)]
)
def test_samples_at_a_sim_time_rate(scene, rate_hz, period_ns):
    model = scene.model("folding_arm.xml")
    sink = CollectingSink()
    positions = {}

    class Probe:
        """A Logger of our own, every step: what the state really was."""

        name = "probe"
        period_ns = 0

        def observe(self, ctx):
            positions[ctx.step] = tuple(ctx.data.qpos)
            return []

        def finish(self, ctx):
            return []

    hub = EventHub([JointLogger(model, rate_hz=rate_hz), Probe()], [sink])
    scene.run(model, hub, 500, swing)  # steps 1..500: 2 ms .. 1 s of sim time
    samples = sink.of_kind(JointSample)
    # a sample at the first step at or after each multiple of the period (n = 0, 1, ...)
    expected_times = sorted(
        {
            max(DT_NS, -(-n * period_ns // DT_NS) * DT_NS)
            for n in range(1_000_000_000 // period_ns + 1)
        }
    )
    assert [s.sim_time_ns for s in samples] == expected_times
    assert all(s.step * DT_NS == s.sim_time_ns for s in samples)
    assert samples[0].joints == ("j1", "j2", "j3")
    for s in samples:
        assert s.positions == positions[s.step]


def test_every_step_without_a_rate(scene):
    model = scene.model("folding_arm.xml")
    sink = CollectingSink()
    scene.run(model, EventHub([JointLogger(model, joints=["j2"])], [sink]), 37, swing)
    samples = sink.of_kind(JointSample)
    assert [s.step for s in samples] == list(range(1, 38))
    assert samples[0].properties()["positions"].keys() == {"j2"}


def test_limit_violation_one_event_with_the_peak(scene):
    model = scene.model("folding_arm.xml")  # j2 range +-2.8
    # no limit constraint: the state after each step is exactly the scripted position
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT

    def script(k, data):
        # j2 beyond 2.8 for k = 100..104, peak 2.95 at k = 102
        over = {100: 2.85, 101: 2.9, 102: 2.95, 103: 2.9, 104: 2.81}
        data.qpos[:] = (0.0, over.get(k, 2.0), 0.0)
        data.qvel[:] = 0.0

    sink = CollectingSink()
    scene.run(model, EventHub([JointLimitLogger(model)], [sink]), 200, script)
    (violation,) = sink.of_kind(JointLimitViolation)
    assert violation.joint == "j2"
    assert violation.limit == pytest.approx(2.8)
    assert violation.amount == pytest.approx(0.15, abs=1e-9)
    assert violation.value == pytest.approx(2.95, abs=1e-9)
    assert violation.peak_step == 103
    assert (violation.begin_step, violation.end_step) == (101, 106)
    assert violation.step == 106
    assert violation.duration_ns == 5 * DT_NS


def test_velocity_limit_exceeded_and_open_episode_closed_at_finish(scene):
    model = scene.model("folding_arm.xml")
    velocities = {}

    def script(k, data):
        data.qpos[:] = 0.0
        data.qvel[:] = (1.5 if k >= 50 else 0.5, 0.0, 0.0)

    def record(k, data):
        script(k, data)
        velocities[k] = data.qvel[0]

    sink = CollectingSink()
    logger = JointLimitLogger(model, velocity_limits={"j1": 1.0}, tolerance=0.01)
    scene.run(model, EventHub([logger], [sink]), 80, record)
    (event,) = sink.of_kind(VelocityLimitExceeded)
    assert event.joint == "j1"
    assert event.at_finish
    assert event.begin_step == 51
    assert event.amount == pytest.approx(0.5, abs=1e-6)
    assert event.limit == 1.0


def test_velocity_limits_from_the_description_and_bad_config(scene):
    robot = RobotModel(
        name="r",
        links=(),
        joints=(
            Joint("j1", "revolute", "a", "b", Pose(), limits=JointLimits(-1, 1, 2.5, 10)),
            Joint("j2", "revolute", "b", "c", Pose()),
        ),
    )
    assert velocity_limits(robot) == {"j1": 2.5}
    model = scene.model("folding_arm.xml")
    with pytest.raises(LoggerConfigError, match=r"joints\[1\].*'nope'"):
        JointLogger(model, joints=["j1", "nope"])
    with pytest.raises(LoggerConfigError, match=r"velocity_limits.*'x'"):
        JointLimitLogger(model, velocity_limits={"x": 1.0})
    with pytest.raises(LoggerConfigError, match="rate_hz"):
        JointLogger(model, rate_hz=-5)
