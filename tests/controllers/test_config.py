"""The controllers YAML, the controller manager's services, and the controllers option on every
surface (Python, marker, scenario, recording metadata)."""

from __future__ import annotations

import sysconfig
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.controllers import (
    ControllerManager,
    ControllersConfig,
    ControllersConfigError,
    JointReadings,
    default_controllers,
    load_controllers,
)
from harness.scenario import Scenario
from harness.session.core import CoreOptions
from harness.testing import connect

DATA = Path(__file__).resolve().parent.parent / "data" / "controllers"
PANDA_YAML = DATA / "panda_ros2_controllers.yaml"
PANDA_URDF = (
    Path(sysconfig.get_paths()["purelib"])
    / "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"
)
PANDA_ARM = [f"panda_joint{i}" for i in range(1, 8)]


def test_reads_a_real_robots_controllers_yaml() -> None:
    config = load_controllers(PANDA_YAML)
    assert config.update_rate == 100.0
    assert [(c.name, c.type) for c in config.controllers] == [
        ("panda_arm_controller", "joint_trajectory_controller/JointTrajectoryController"),
        ("panda_hand_controller", "position_controllers/GripperActionController"),
        ("joint_state_broadcaster", "joint_state_broadcaster/JointStateBroadcaster"),
    ]
    assert config.controllers[0].params["joints"] == PANDA_ARM
    assert ControllersConfig.from_json(config.to_json()) == config


@pytest.mark.harness(
    robot=str(PANDA_URDF), controllers="../data/controllers/panda_ros2_controllers.yaml"
)
def test_real_yaml_configures_the_session_from_the_marker(harness_session: Session) -> None:
    with connect(harness_session.url) as client:
        listing = client.call_service("/controller_manager/list_controllers")["controller"]
        states = {c["name"]: (c["state"], c["type"]) for c in listing}
        assert states == {
            "panda_arm_controller": (
                "active",
                "joint_trajectory_controller/JointTrajectoryController",
            ),
            "panda_hand_controller": ("active", "position_controllers/GripperActionController"),
            "joint_state_broadcaster": ("active", "joint_state_broadcaster/JointStateBroadcaster"),
        }
        hw = client.call_service("/controller_manager/list_hardware_interfaces")
        claimed = {i["name"] for i in hw["command_interfaces"] if i["is_claimed"]}
        assert claimed == {f"{j}/position" for j in [*PANDA_ARM, "panda_finger_joint1"]}
        actions = client.call_service("/rosapi/action_servers")["action_servers"]
        assert "/panda_arm_controller/follow_joint_trajectory" in actions
        assert "/panda_hand_controller/gripper_cmd" in actions
        topics = client.call_service("/rosapi/topics")
        types = dict(zip(topics["topics"], topics["types"], strict=True))
        assert types["/panda_arm_controller/controller_state"] == (
            "control_msgs/msg/JointTrajectoryControllerState"
        )
        assert types["/panda_arm_controller/joint_trajectory"] == (
            "trajectory_msgs/msg/JointTrajectory"
        )


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("arm:\n  ros__parameters: {}\n", "no controllers: no node section has a 'type:'"),
        ("controller_manager:\n  ros__parameters:\n    update_rate: -1\n", "update_rate"),
        (
            "controller_manager:\n  ros__parameters:\n    arm:\n      type: 3\n",
            "controller_manager.arm.type must be a plugin name",
        ),
        ("controller_manager: [1, 2\n", "not valid YAML (line"),
    ],
)
def test_bad_yaml_is_one_clear_line(text: str, words: str) -> None:
    with pytest.raises(ControllersConfigError, match=r"^controllers: ") as info:
        load_controllers(text)
    assert words in str(info.value)
    assert "\n" not in str(info.value)


def test_a_joint_the_robot_lacks_is_refused_naming_file_and_controller(tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(PANDA_YAML.read_text())
    with pytest.raises(ControllersConfigError) as info:
        Session("demo", controllers=path)
    text = str(info.value)
    assert str(path) in text
    assert "'panda_arm_controller'" in text
    assert "'panda_joint1' is not a controllable joint" in text


def test_unknown_types_load_unconfigured() -> None:
    config = load_controllers(
        "controller_manager:\n  ros__parameters:\n    io:\n      type: vendor/IOController\n"
    )
    manager = ControllerManager(config, {"a": "position"}, ["a"], lambda: _state())
    manager.start()
    response, _ = manager.handle("list_controllers", {})
    assert [(c["name"], c["state"]) for c in response["controller"]] == [("io", "unconfigured")]
    assert manager.handle("configure_controller", {"name": "io"})[0] == {"ok": False}


def _state() -> JointReadings:
    zero = {"a": 0.0, "b": 0.0}
    return JointReadings(0, zero, zero, zero)


YAML_TWO = """
controller_manager:
  ros__parameters:
    update_rate: 50
    traj:
      type: joint_trajectory_controller/JointTrajectoryController
    fwd:
      type: position_controllers/JointGroupPositionController
traj:
  ros__parameters:
    joints: [a, b]
fwd:
  ros__parameters:
    joints: [a, b]
"""


def _manager() -> ControllerManager:
    manager = ControllerManager(
        load_controllers(YAML_TWO), {"a": "position", "b": "position"}, ["a", "b"], _state
    )
    manager.start()
    return manager


def _states(manager: ControllerManager) -> dict[str, str]:
    return {c["name"]: c["state"] for c in manager.handle("list_controllers", {})[0]["controller"]}


def test_conflicting_controllers_stay_inactive_and_switch_semantics() -> None:
    manager = _manager()
    assert manager.update_period_ns == 20_000_000
    assert _states(manager) == {"traj": "active", "fwd": "inactive"}
    # STRICT: activating fwd while traj claims the joints fails as a whole
    ok, out = manager.handle(
        "switch_controller", {"activate_controllers": ["fwd"], "strictness": 2}
    )
    assert ok == {"ok": False}
    assert out.logs[0].text == (
        "switch_controller: Unable to activate controller 'fwd' since the command interface "
        "'a/position' is currently claimed by another controller."
    )
    assert _states(manager) == {"traj": "active", "fwd": "inactive"}
    # both ways at once succeeds
    ok, _ = manager.handle(
        "switch_controller",
        {"activate_controllers": ["fwd"], "deactivate_controllers": ["traj"], "strictness": 2},
    )
    assert ok == {"ok": True}
    assert _states(manager) == {"traj": "inactive", "fwd": "active"}
    # BEST_EFFORT skips the unknown one
    ok, _ = manager.handle(
        "switch_controller",
        {"deactivate_controllers": ["fwd", "ghost"], "strictness": 1},
    )
    assert ok == {"ok": True}
    assert _states(manager) == {"traj": "inactive", "fwd": "inactive"}


def test_deactivating_the_trajectory_controller_aborts_its_goal() -> None:
    manager = _manager()
    traj = manager.loaded["traj"].controller
    goal = {
        "trajectory": {
            "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
            "joint_names": ["a", "b"],
            "points": [{"positions": [1.0, 1.0], "time_from_start": {"sec": 1, "nanosec": 0}}],
        }
    }
    assert not traj.on_goal("~/follow_joint_trajectory", 3, goal, _state()).results
    _, out = manager.handle("switch_controller", {"deactivate_controllers": ["traj"]})
    assert [(r.goal, r.status, r.values["error_code"]) for r in out.results] == [(3, 6, -1)]


def test_load_configure_unload_answer_truthfully() -> None:
    manager = _manager()
    assert manager.handle("load_controller", {"name": "traj"})[0] == {"ok": False}  # loaded
    assert manager.handle("unload_controller", {"name": "traj"})[0] == {"ok": False}  # active
    assert manager.handle("unload_controller", {"name": "fwd"})[0] == {"ok": True}
    assert "fwd" not in _states(manager)
    assert manager.handle("configure_controller", {"name": "fwd"})[0] == {"ok": False}
    assert manager.handle("load_controller", {"name": "fwd"})[0] == {"ok": True}
    assert _states(manager)["fwd"] == "unconfigured"
    assert manager.handle("configure_controller", {"name": "fwd"})[0] == {"ok": True}
    assert _states(manager)["fwd"] == "inactive"
    assert manager.handle("load_controller", {"name": "nope"})[0] == {"ok": False}


def test_default_set_of_the_demo_arm() -> None:
    control = {f"joint{i}": "position" for i in range(1, 8)} | {"finger_joint1": "position"}
    config = default_controllers(list(control), control)
    by_name = {c.name: c for c in config.controllers}
    assert by_name["joint_trajectory_controller"].params["joints"] == [
        f"joint{i}" for i in range(1, 8)
    ]
    assert by_name["gripper_controller"].params["joint"] == "finger_joint1"
    assert "joint_state_broadcaster" in by_name
    assert not config.exclusive


def test_options_survive_the_recording_metadata() -> None:
    config = load_controllers(PANDA_YAML)
    for value in (config, "default", "none"):
        options = CoreOptions(controllers=value)
        assert CoreOptions.from_metadata(options.to_metadata()).controllers == value
    # a recording made before controllers existed replays without them
    old = CoreOptions().to_metadata()
    del old["controllers"]
    assert CoreOptions.from_metadata(old).controllers == "none"


def test_scenario_controllers_key(tmp_path: Path) -> None:
    (tmp_path / "c.yaml").write_text(YAML_TWO)
    inline: dict[str, Any] = {"controller_manager": {"ros__parameters": {"update_rate": 10}}}
    from_file = Scenario.from_mapping(
        {"robots": [{"robot": "demo"}], "controllers": "c.yaml"}, base_dir=tmp_path
    )
    assert from_file.controllers is not None
    assert [c.name for c in from_file.controllers.controllers] == ["traj", "fwd"]
    from_inline = Scenario.from_mapping({"robots": [{"robot": "demo"}], "controllers": inline})
    assert from_inline.controllers is not None
    assert from_inline.controllers.update_rate == 10
    with pytest.raises(Exception, match="controllers"):
        Scenario.from_mapping(
            {"robots": [{"robot": "demo"}], "controllers": "missing.yaml"}, base_dir=tmp_path
        )


def test_controllers_false_turns_them_off() -> None:
    with Session("demo", controllers=False) as session, connect(session.url) as client:
        services = client.call_service("/rosapi/services")["services"]
        assert not [s for s in services if s.startswith("/controller_manager/")]


def test_each_robot_of_a_world_has_its_own_controller_manager() -> None:
    from harness.models import RobotSpec

    world = [
        RobotSpec("demo", namespace="left", pose=[0.0, -0.7, 0.0], control="position"),
        RobotSpec("demo", namespace="right", pose=[0.0, 0.7, 0.0], control="kinematic"),
    ]
    with Session(robots=world) as session, connect(session.url) as client:
        for ns in ("left", "right"):
            listing = client.call_service(f"/{ns}/controller_manager/list_controllers")
            names = [c["name"] for c in listing["controller"]]
            assert "joint_trajectory_controller" in names
        actions = client.call_service("/rosapi/action_servers")["action_servers"]
        assert "/left/joint_trajectory_controller/follow_joint_trajectory" in actions
        assert "/right/gripper_controller/gripper_cmd" in actions
