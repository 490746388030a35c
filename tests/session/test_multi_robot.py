"""Two demo arms in one Session: namespaced topics, independent commands, per-robot control
modes, collisions between robots with prefixed body names, bit-exact replay of the recording
(physics and ``--level full``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness import cli
from harness.events import CollectingSink, CollisionBegin, CollisionLogger
from harness.models import RobotSpec, load_world
from harness.recording import Recording
from harness.session import Session, SessionConfigError
from harness.testing import connect

JOINT_STATE = "sensor_msgs/msg/JointState"
FORWARD = "std_msgs/msg/Float64MultiArray"
TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
HOME = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4, 0.04]


def _far_apart() -> list[RobotSpec]:
    # Left: dynamic position servos; right: kinematic. 1.4 m apart: they cannot touch.
    return [
        RobotSpec("demo", namespace="left", pose=[0.0, -0.7, 0.0], control="position"),
        RobotSpec("demo", namespace="right", pose=[0.0, 0.7, 0.0], control="kinematic"),
    ]


def _drive(url: str, *, left: bool, right: bool) -> tuple[list[list[float]], list[list[float]]]:
    """A client commanding the left arm on /left/joint_command and/or the right arm on its
    forward position controller; returns both arms' /<ns>/joint_states positions."""
    with connect(url) as client:
        left_states = client.subscribe("/left/joint_states", JOINT_STATE)
        right_states = client.subscribe("/right/joint_states", JOINT_STATE)
        client.sync()
        for k in range(1, 101):
            if left:
                client.publish(
                    "/left/joint_command",
                    JOINT_STATE,
                    {"name": ["joint1", "joint4"], "position": [0.004 * k, -2.3 + 0.001 * k]},
                )
            if right:
                target = [*HOME]
                target[0] = -0.006 * k
                client.publish(
                    "/right/forward_position_controller/commands", FORWARD, {"data": target}
                )
            client.step(5)
        client.sync()
        assert not client.statuses, client.statuses
        return (
            [m["position"] for m in left_states.messages],
            [m["position"] for m in right_states.messages],
        )


def test_two_arms_move_independently_over_their_namespaced_topics():
    world = load_world(_far_apart(), scene="empty")
    runs = {}
    for label, left, right in (("both", True, True), ("left", True, False)):
        with Session(robots=world) as session:
            assert session.namespaces == ("left", "right")
            assert session.joint_names_of("right") == (
                "joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7",
                "finger_joint1",
            )  # fmt: skip
            runs[label] = _drive(session.url, left=left, right=right)
            runs[label + "_final"] = (
                session.joint_positions("left"),
                session.joint_positions("right"),
            )
    left_both, right_both = (np.array(r) for r in runs["both"])
    left_only, right_still = (np.array(r) for r in runs["left"])
    # Each arm followed its own commands ...
    assert runs["both_final"][0][0] == pytest.approx(0.4, abs=0.02)
    assert runs["both_final"][1][0] == -0.6  # kinematic: exactly the commanded position
    assert right_both[-1][0] == -0.6
    # ... and the right arm's commands did not move the left arm (same stream as without them),
    np.testing.assert_allclose(left_both, left_only, rtol=0, atol=1e-9)
    assert np.ptp(left_only[:, 0]) > 0.3
    # while the left arm's commands never moved the right arm (kinematic: held bit for bit).
    assert (right_still == right_still[0]).all()
    assert right_still[0][:7] == pytest.approx(HOME[:7])


def test_topics_names_and_frames_of_a_two_robot_session():
    with Session(robots=_far_apart(), scene="empty") as session:
        topics = session.robot_topics
        assert topics["left"].joint_states == "/left/joint_states"
        assert topics["right"].joint_command == "/right/joint_command"
        assert topics["right"].forward["effort"] == "/right/forward_effort_controller/commands"
        assert topics["left"].tf == topics["right"].tf == "/tf"
        with connect(session.url) as client:
            description = client.subscribe("/right/robot_description", "std_msgs/msg/String")
            tf = client.subscribe("/tf", "tf2_msgs/msg/TFMessage")
            tf_static = client.subscribe("/tf_static", "tf2_msgs/msg/TFMessage")
            states = client.subscribe("/left/joint_states", JOINT_STATE)
            text = description.wait_for_message(sim_timeout=0.1)["data"]
            assert '<robot name="demo_arm"' in text
            msg = states.wait_for_message(sim_timeout=0.1)
            assert msg["name"][:2] == ["joint1", "joint2"]
            frames = {
                t["child_frame_id"]: t for t in tf.wait_for_message(sim_timeout=0.1)["transforms"]
            }
            assert {"left/link1", "right/link1", "left/left_finger"} <= set(frames)
            assert frames["right/link1"]["header"]["frame_id"] == "right/link0"
            # fixed transforms of both robots come latched on the one /tf_static
            fixed = {
                t["child_frame_id"]: t
                for t in tf_static.wait_for_message(sim_timeout=0.1)["transforms"]
            }
            assert set(fixed) == {"left/link0", "right/link0", "left/hand", "right/hand"}
            assert fixed["left/link0"]["transform"]["translation"]["y"] == pytest.approx(-0.7)
            assert fixed["right/link0"]["transform"]["translation"]["y"] == pytest.approx(0.7)
            assert fixed["left/link0"]["header"]["frame_id"] == "world"
            assert fixed["left/hand"]["header"]["frame_id"] == "left/link7"
            # each robot's nodes live in its namespace; both publish the one /tf
            assert client.call_service("/rosapi/publishers", {"topic": "/tf"}) == {
                "publishers": ["/left/robot_state_publisher", "/right/robot_state_publisher"]
            }
            assert client.call_service("/rosapi/publishers", {"topic": "/left/joint_states"}) == {
                "publishers": ["/left/joint_state_broadcaster"]
            }
            # A robot's command topics take its own joint names only.
            client.publish(
                "/left/joint_command", JOINT_STATE, {"name": ["right/joint1"], "position": [1.0]}
            )
            client.publish("/right/forward_position_controller/commands", FORWARD, {"data": [0.0]})
            client.sync()
            texts = [s["msg"] for s in client.statuses]
            assert any(
                t.startswith("/left/joint_command: command refused: unknown joint 'right/joint1'")
                for t in texts
            ), texts
            assert any(
                "/right/forward_position_controller/commands: command refused: expected 8 values"
                in t
                for t in texts
            ), texts
            state = client.state()["joint_state"]
            assert state["name"][0] == "left/joint1"
            assert state["name"][9] == "right/joint1"
        assert session.joint_commands("right")[0] == 0.0  # nothing changed


@pytest.mark.slow
def test_two_arms_collide_and_the_recording_replays_bit_exactly(tmp_path):
    path = tmp_path / "two-arms.mcap"
    sink = CollectingSink()
    robots = [
        RobotSpec("demo", namespace="left", pose=[0.0, -0.35, 0.0], control="kinematic"),
        RobotSpec("demo", namespace="right", pose=[0.0, 0.35, 0.0], control="position"),
    ]
    with (
        Session(
            robots=robots,
            scene="empty",
            record_to=path,
            loggers=[lambda s: CollisionLogger(s.model, debounce_steps=2)],
            sinks=[sink],
        ) as session,
        connect(session.url) as client,
    ):
        for namespace, angle in (("left", 1.57), ("right", -1.57)):
            client.publish(
                f"/{namespace}/joint_trajectory",
                TRAJECTORY,
                {
                    "joint_names": ["joint1"],
                    "points": [
                        {"positions": [angle], "time_from_start": {"sec": 0, "nanosec": 10**8}}
                    ],
                },
            )
        client.step(500)
    begins = [e for e in sink.events if isinstance(e, CollisionBegin)]
    pairs = {tuple(sorted((e.body1, e.body2))) for e in begins}
    assert any(a.startswith("left/") and b.startswith("right/") for a, b in pairs), pairs
    with Recording(path) as rec:
        assert {"/left/joint_states", "/right/joint_states", "/tf", "/clock"} <= set(rec.topics)
        assert rec.topics["/harness/collisions"].messages >= 1
    assert cli.main(["replay", str(path)]) == 0
    assert cli.main(["replay", str(path), "--level", "full"]) == 0


def test_robot_and_robots_are_exclusive_and_topics_must_not_collide():
    with pytest.raises(SessionConfigError, match="not both"):
        Session("demo", robots=_far_apart())
    with pytest.raises(SessionConfigError, match="give each RobotSpec its control"):
        Session(robots=_far_apart(), mode="kinematic")
    with pytest.raises(SessionConfigError, match="topic /cmd is robot 'right'"):
        Session(robots=_far_apart(), scene="empty", joint_command_topic="/cmd")
    # Per-robot command topics by namespace.
    with Session(
        robots=_far_apart(), scene="empty", joint_command_topic={"left": "/left_arm/cmd"}
    ) as session:
        assert session.robot_topics["left"].joint_command == "/left_arm/cmd"
        assert session.robot_topics["right"].joint_command == "/right/joint_command"


def test_the_pytest_marker_takes_robots_and_the_suite_mode(pytester):
    pytester.makepyfile(
        test_two="""
        import pytest
        from harness.models import RobotSpec

        ROBOTS = [
            RobotSpec("demo", namespace="left", pose=[0, -0.7, 0]),
            RobotSpec("demo", namespace="right", pose=[0, 0.7, 0], control="velocity"),
        ]

        @pytest.mark.harness(robots=ROBOTS, scene="empty")
        def test_world(harness_session, harness_recording):
            assert harness_session.namespaces == ("left", "right")
            modes = harness_session.world.control
            assert modes["right/joint1"] == pytest.config_mode_right
            assert modes["left/joint1"] == pytest.config_mode_left
            assert harness_session.step(5) == 5
        """
    )
    pytester.makeconftest(
        """
        import pytest

        def pytest_configure(config):
            kinematic = config.getoption("--harness-mode") == "kinematic"
            pytest.config_mode_left = "kinematic" if kinematic else "position"
            pytest.config_mode_right = "kinematic" if kinematic else "velocity"
        """
    )
    for args in ((), ("--harness-mode=kinematic",)):
        result = pytester.runpytest_inprocess("-p", "no:cacheprovider", *args)
        result.assert_outcomes(passed=1)
