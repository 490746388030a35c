"""ros2_control's resource rules and the one command path (issues 32 and 34).

- One active claim per command interface among the controllers a YAML names: a switch that
  would claim one twice is refused as ros2_control's controller manager refuses it, with its
  messages (``controller_manager.cpp``: ``check_for_interfaces_availability_to_activate``).
- A YAML that names controllers replaces the default set and its topics entirely.
- The default set keeps every command path of before by sharing the joints through the
  harness's multiplexer (``command_mux``), itself a controller like any other: listed,
  switchable, chained to by the set's other controllers.
- ``update_rate`` of the manager and of each controller, and ``publish_rate``, in simulation
  time: a message at the first step at or after each period.

The YAMLs are ros2_control_demos' own (example_1 RRBot, example_2 DiffBot), vendored in
``tests/data/controllers/ros2_control_demos``; the manager's ``update_rate`` is what their
launch files give ``ros2_control_node`` (10 Hz).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from harness import Session
from harness.controllers import ControllerManager, JointReadings, load_controllers
from harness.models import load_robot
from harness.testing import connect

DEMOS = Path(__file__).resolve().parents[1] / "data" / "controllers" / "ros2_control_demos"
RRBOT = DEMOS / "example_1" / "bringup" / "config" / "rrbot_controllers.yaml"
RRBOT_JTC = DEMOS / "example_1" / "bringup" / "config" / "rrbot_jtc.yaml"
DIFFBOT_URDF = DEMOS / "example_2" / "description" / "urdf" / "diffbot.urdf.xacro"
DIFFBOT = DEMOS / "example_2" / "bringup" / "config" / "diffbot_controllers.yaml"
DIFFBOT_PACKAGES = {
    "ros2_control_demo_example_2": DEMOS / "example_2" / "description",
    "ros2_control_demo_description": DEMOS / "ros2_control_demo_description",
}
ARGS = {"joint_prefix": "joint"}  # rrbot.launch.py's default
JTC = "joint_trajectory_position_controller"
FORWARD = "forward_position_controller"


def _rate(hz: float) -> dict[str, Any]:
    """What a launch file gives ``ros2_control_node``: ``parameters=[{"update_rate": hz}]``."""
    return {"controller_manager": {"ros__parameters": {"update_rate": hz}}}


def _state() -> JointReadings:
    zero = {"joint1": 0.0, "joint2": 0.0}
    return JointReadings(0, zero, zero, zero)


def _states(manager: ControllerManager) -> dict[str, str]:
    listing = manager.handle("list_controllers", {})[0]["controller"]
    return {c["name"]: c["state"] for c in listing}


def _claimed(interface: str, name: str) -> str:
    return (
        f"switch_controller: Unable to activate controller '{name}' since the command "
        f"interface '{interface}' is currently claimed by another controller."
    )


def test_a_switch_that_would_double_claim_is_refused_as_ros2_control_refuses_it() -> None:
    config = load_controllers([RRBOT, RRBOT_JTC], ARGS)
    control = {"joint1": "position", "joint2": "position"}
    manager = ControllerManager(config, control, list(control), _state)
    # spawned in file order: the trajectory controller finds joint1/position claimed
    assert [log.text for log in manager.start().logs] == [
        f"Unable to activate controller '{JTC}' since the command interface 'joint1/position' "
        "is currently claimed by another controller. (left inactive)"
    ]
    before = {"joint_state_broadcaster": "active", FORWARD: "active", JTC: "inactive"}
    assert _states(manager) == before
    # refused as a whole whatever the strictness (BEST_EFFORT, STRICT, the default)
    for strictness in (1, 2, 0):
        response, out = manager.handle(
            "switch_controller", {"activate_controllers": [JTC], "strictness": strictness}
        )
        assert response == {"ok": False}
        assert [log.text for log in out.logs] == [_claimed("joint1/position", JTC)]
        assert _states(manager) == before
    # two controllers activated at once on the same interfaces
    assert manager.handle("switch_controller", {"deactivate_controllers": [FORWARD]})[0]["ok"]
    response, out = manager.handle(
        "switch_controller", {"activate_controllers": [FORWARD, JTC], "strictness": 1}
    )
    assert response == {"ok": False}
    assert [log.text for log in out.logs] == [
        f"switch_controller: Unable to activate controller '{JTC}' since the command "
        "interface 'joint1/position' will be used by another controller that is being "
        "activated."
    ]
    # the swap ros2_control allows: one leaves, the other comes, in one switch
    response, _ = manager.handle(
        "switch_controller",
        {"activate_controllers": [JTC], "deactivate_controllers": [], "strictness": 2},
    )
    assert response == {"ok": True}
    response, _ = manager.handle(
        "switch_controller",
        {"activate_controllers": [FORWARD], "deactivate_controllers": [JTC], "strictness": 2},
    )
    assert response == {"ok": True}
    claimed = {
        c["name"]: c["claimed_interfaces"]
        for c in manager.handle("list_controllers", {})[0]["controller"]
    }
    assert claimed == {
        "joint_state_broadcaster": [],
        FORWARD: ["joint1/position", "joint2/position"],
        JTC: [],
    }


def test_a_controllers_yaml_replaces_the_default_set_and_its_topics() -> None:
    config = load_controllers(RRBOT, ARGS)
    with Session("demo", controllers=config) as session, connect(session.url) as client:
        listing = client.call_service("/controller_manager/list_controllers")["controller"]
        assert {c["name"] for c in listing} == {"joint_state_broadcaster", FORWARD}
        topics = client.call_service("/rosapi/topics")["topics"]
        for gone in (
            "/joint_command",
            "/joint_trajectory",
            "/forward_velocity_controller/commands",
            "/forward_effort_controller/commands",
            "/joint_trajectory_controller/joint_trajectory",
        ):
            assert gone not in topics
        assert f"/{FORWARD}/commands" in topics
        # the YAML's forward controller drives joint1 and joint2 only
        client.publish(
            f"/{FORWARD}/commands", "std_msgs/msg/Float64MultiArray", {"data": [0.3, -0.2]}
        )
        client.step(300)
        positions = dict(zip(session.joint_names, session.joint_positions(), strict=True))
        assert abs(positions["joint1"] - 0.3) < 0.01
        assert abs(positions["joint2"] + 0.2) < 0.01


def _list(client: Any) -> Mapping[str, Mapping[str, Any]]:
    listing = client.call_service("/controller_manager/list_controllers")["controller"]
    return {c["name"]: c for c in listing}


def test_the_default_set_shares_the_joints_through_one_switchable_multiplexer() -> None:
    joint_state = "sensor_msgs/msg/JointState"
    with Session("demo") as session, connect(session.url) as client:
        listed = _list(client)
        mux = listed["command_mux"]
        assert mux["state"] == "active"
        assert mux["is_chainable"]
        assert mux["is_chained"]
        assert "joint1/position" in mux["claimed_interfaces"]
        # every other command controller claims the multiplexer's shared references
        claims = {
            name: c["claimed_interfaces"] for name, c in listed.items() if name != "command_mux"
        }
        assert claims["forward_position_controller"][0] == "command_mux/joint1/position"
        assert claims["joint_trajectory_controller"][0] == "command_mux/joint1/position"
        hardware = [i for c in claims.values() for i in c if not i.startswith("command_mux/")]
        assert hardware == []
        # the multiplexer follows the others: it cannot leave while they command through it
        switch = "/controller_manager/switch_controller"
        refused = client.call_service(
            switch, {"deactivate_controllers": ["command_mux"], "strictness": 2}
        )
        assert refused == {"ok": False}
        assert _list(client)["command_mux"]["state"] == "active"
        # all of them off: /joint_command is the multiplexer's, so it is ignored
        routed = [n for n, c in claims.items() if c]
        off = client.call_service(
            switch, {"deactivate_controllers": [*routed, "command_mux"], "strictness": 2}
        )
        assert off == {"ok": True}
        command = {"name": ["joint1"], "position": [0.4], "velocity": [], "effort": []}
        client.publish("/joint_command", joint_state, command)
        client.step(200)
        assert abs(session.joint_positions()[0]) < 0.01
        assert any(
            "/joint_command: inactive, command ignored" in str(s.get("msg"))
            for s in client.statuses
        )
        # back on (the multiplexer first, as ros2_control orders a chain): it drives again
        on = client.call_service(
            switch, {"activate_controllers": [*routed, "command_mux"], "strictness": 2}
        )
        assert on == {"ok": True}
        client.publish("/joint_command", joint_state, command)
        client.step(300)
        assert abs(session.joint_positions()[0] - 0.4) < 0.01


def _count(session: Session, topic: str) -> int:
    return session.core.publish_counts.count(topic)


def test_joint_states_follow_the_manager_and_the_broadcaster_rates() -> None:
    # example_1 as rrbot.launch.py starts it: the manager at 10 Hz, the broadcaster asking
    # for 50 Hz (ros2_control updates it at the manager's 10 Hz)
    config = load_controllers([RRBOT, _rate(10)], ARGS)
    with Session("demo", controllers=config) as session:
        dt = session.model.opt.timestep
        session.step(round(10.0 / dt))  # 10 s
        assert abs(_count(session, "/joint_states") - 101) <= 1  # steps 0, 0.1 s, ... 10 s
    # a rate that does not divide the step: 30 Hz at 2 ms steps and a 100 Hz manager
    rrbot = load_controllers([RRBOT, _rate(100)], ARGS)
    jsb = rrbot.controllers[0]
    assert jsb.name == "joint_state_broadcaster"
    params = dict(jsb.params) | {"update_rate": 30}
    config = type(rrbot)(
        rrbot.update_rate, (type(jsb)(jsb.name, jsb.type, params), *rrbot.controllers[1:])
    )
    with Session("demo", controllers=config) as session:
        dt = session.model.opt.timestep
        session.step(round(10.0 / dt))
        assert abs(_count(session, "/joint_states") - 301) <= 1


def test_odometry_follows_its_publish_rate_in_simulation_time() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the xacro's hardware plugin is replaced
        robot = load_robot(DIFFBOT_URDF, base="floating", packages=DIFFBOT_PACKAGES)
    odom = "/diffbot_base_controller/odom"
    # diffbot.launch.py's manager runs at 10 Hz: the 50 Hz publish_rate gets 10 Hz
    with Session(robot, controllers=load_controllers([DIFFBOT, _rate(10)])) as session:
        dt = session.model.opt.timestep
        session.step(round(10.0 / dt))
        assert abs(_count(session, odom) - 101) <= 1
        assert abs(_count(session, "/joint_states") - 101) <= 1
    # 30 Hz (a Gazebo plugin's rate) under a 100 Hz manager: 30 a second, not 25
    thirty = {"diffbot_base_controller": {"ros__parameters": {"publish_rate": 30.0}}}
    with Session(robot, controllers=load_controllers([DIFFBOT, thirty, _rate(100)])) as session:
        dt = session.model.opt.timestep
        session.step(round(10.0 / dt))
        assert abs(_count(session, odom) - 301) <= 1


CLASSIC_DRIVE = """
  <gazebo>
    <plugin name="wheels" filename="libgazebo_ros_diff_drive.so">
      <left_joint>left_wheel_joint</left_joint>
      <right_joint>right_wheel_joint</right_joint>
      <wheel_separation>0.16</wheel_separation>
      <wheel_diameter>0.066</wheel_diameter>
      <command_topic>cmd_vel</command_topic>
      <odometry_topic>wheel_odom</odometry_topic>
      <update_rate>30</update_rate>
    </plugin>
  </gazebo>
"""


def test_a_drive_plugin_in_the_robot_file_replaces_the_default_set(tmp_path: Path) -> None:
    from harness.models.mobile import MOBILE_URDF

    text = re.sub(
        r"<ros2_control.*</ros2_control>", CLASSIC_DRIVE, MOBILE_URDF.read_text(), flags=re.DOTALL
    )
    path = tmp_path / "plugin_bot.urdf"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(path, base="floating")
    with Session(robot) as session, connect(session.url) as client:
        assert set(_list(client)) == {"joint_state_broadcaster", "wheels"}
        topics = client.call_service("/rosapi/topics")["topics"]
        assert "/cmd_vel" in topics
        for gone in (
            "/joint_command",
            "/joint_trajectory",
            "/forward_velocity_controller/commands",
        ):
            assert gone not in topics
        # the plugin's <update_rate> is its odometry's rate, in simulation time
        dt = session.model.opt.timestep
        session.step(round(10.0 / dt))
        assert abs(_count(session, "/wheel_odom") - 301) <= 1
