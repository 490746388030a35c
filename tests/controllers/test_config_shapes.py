"""Every shape of controllers YAML ros2_control accepts: the ros2_control_demos files as they
ship (no ``controller_manager:`` section, ``type:`` in each controller's own section,
``$(var NAME)`` launch substitutions), wildcard and namespaced node keys, several files merged
in order, and the ``controllers_args`` option on every surface (Python, CLI, marker, scenario)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from harness import Session
from harness.controllers import ControllersConfigError, load_controllers
from harness.scenario import Scenario
from harness.testing import connect

DEMOS = Path(__file__).resolve().parent.parent / "data" / "controllers" / "ros2_control_demos"
RRBOT = DEMOS / "example_1/bringup/config/rrbot_controllers.yaml"
RRBOT_JTC = DEMOS / "example_1/bringup/config/rrbot_jtc.yaml"
DIFFBOT = DEMOS / "example_2/bringup/config/diffbot_controllers.yaml"
RRBOT_9 = DEMOS / "example_9/bringup/config/rrbot_controllers.yaml"
CARLIKE = DEMOS / "example_11/bringup/config/carlikebot_controllers.yaml"
MODULAR = (
    DEMOS / "example_14/bringup/config/"
    "rrbot_modular_actuators_without_feedback_sensors_for_position_feedback.yaml"
)
JSB = ("joint_state_broadcaster", "joint_state_broadcaster/JointStateBroadcaster")


def test_example_1_rrbot_without_a_manager_section_and_with_var() -> None:
    config = load_controllers(RRBOT, {"joint_prefix": "joint"})
    assert config.update_rate == 100.0  # the manager's default: the file has no section
    assert [(c.name, c.type) for c in config.controllers] == [
        JSB,
        ("forward_position_controller", "forward_command_controller/ForwardCommandController"),
    ]
    jsb, forward = config.controllers
    assert dict(jsb.params) == {"update_rate": 50}  # the broadcaster's own rate stays its own
    assert dict(forward.params) == {"joints": ["joint1", "joint2"], "interface_name": "position"}
    assert config.source == str(RRBOT)


def test_example_2_diffbot_reads_its_drive_parameters() -> None:
    config = load_controllers(DIFFBOT)
    assert [(c.name, c.type) for c in config.controllers] == [
        JSB,
        ("diffbot_base_controller", "diff_drive_controller/DiffDriveController"),
    ]
    drive = config.controllers[1].params
    assert drive["left_wheel_names"] == ["left_wheel_joint"]
    assert drive["right_wheel_names"] == ["right_wheel_joint"]
    assert drive["wheel_separation"] == 0.10
    assert drive["wheel_radius"] == 0.015
    assert drive["linear.x.max_velocity"] == 1.0
    assert drive["open_loop"] is True
    assert "type" not in drive


@pytest.mark.parametrize(
    ("path", "rate", "second"),
    [
        (RRBOT_9, 1000.0, ("forward_position_controller", "interface_name", "position")),
        (CARLIKE, 10.0, ("bicycle_steering_controller", "wheelbase", 0.325)),
        (MODULAR, 10.0, ("forward_velocity_controller", "interface_name", "velocity")),
    ],
)
def test_manager_section_plus_typed_controller_sections(
    path: Path, rate: float, second: tuple[str, str, object]
) -> None:
    config = load_controllers(path)
    assert config.update_rate == rate
    assert [c.name for c in config.controllers] == ["joint_state_broadcaster", second[0]]
    assert config.controllers[1].params[second[1]] == second[2]


def test_a_missing_var_is_one_line_naming_it_and_the_file() -> None:
    with pytest.raises(ControllersConfigError) as info:
        load_controllers(RRBOT, {"other": "x"})
    text = str(info.value)
    assert text.startswith(f"{RRBOT}: line 11: $(var joint_prefix) has no value")
    assert "--controllers-arg joint_prefix:=VALUE" in text
    assert "\n" not in text


def test_var_expands_before_parsing_and_in_inline_mappings() -> None:
    text = "arm:\n  ros__parameters:\n    type: a/B\n    rate: $(var rate)\n"
    assert load_controllers(text, {"rate": 25}).controllers[0].params["rate"] == 25
    inline = {"arm": {"ros__parameters": {"type": "a/B", "joints": ["$(var p)1"], "r": "$(var r)"}}}
    params = load_controllers(inline, {"p": "j", "r": "2.5"}).controllers[0].params
    assert params["joints"] == ["j1"]
    assert params["r"] == 2.5
    with pytest.raises(ControllersConfigError, match=r"\$\(find-pkg-share x\) is not supported"):
        load_controllers("arm:\n  ros__parameters:\n    type: $(find-pkg-share x)\n")


def test_wildcard_and_namespaced_keys() -> None:
    text = """
/**:
  ros__parameters:
    use_sim_time: true
/**/controller_manager:
  ros__parameters:
    update_rate: 200
/robot1/arm_controller:
  ros__parameters:
    type: joint_trajectory_controller/JointTrajectoryController
    joints: [a, b]
/**/joint_state_broadcaster:
  ros__parameters:
    type: joint_state_broadcaster/JointStateBroadcaster
"""
    config = load_controllers(text)
    assert config.update_rate == 200
    assert [c.name for c in config.controllers] == ["arm_controller", "joint_state_broadcaster"]
    assert dict(config.controllers[0].params) == {"use_sim_time": True, "joints": ["a", "b"]}
    namespaced = load_controllers(
        "/ns/controller_manager:\n  ros__parameters:\n    update_rate: 30\n"
        "    jsb:\n      type: joint_state_broadcaster/JointStateBroadcaster\n"
    )
    assert namespaced.update_rate == 30
    assert [c.name for c in namespaced.controllers] == ["jsb"]


def test_several_files_merge_in_order(tmp_path: Path) -> None:
    override = tmp_path / "override.yaml"
    override.write_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 500\n"
        "forward_position_controller:\n  ros__parameters:\n    interface_name: velocity\n"
    )
    config = load_controllers([RRBOT, RRBOT_JTC, override], {"joint_prefix": "joint"})
    assert config.update_rate == 500
    assert [c.name for c in config.controllers] == [
        "joint_state_broadcaster",
        "forward_position_controller",
        "joint_trajectory_position_controller",
    ]
    forward = config.controllers[1].params
    assert forward["interface_name"] == "velocity"
    assert forward["joints"] == ["joint1", "joint2"]
    jtc = config.controllers[2].params
    assert jtc["constraints"] == {"stopped_velocity_tolerance": 0.01, "goal_time": 0.0}
    assert config.source == f"{RRBOT} + {RRBOT_JTC} + {override}"
    nested = tmp_path / "nested.yaml"
    nested.write_text(
        "joint_trajectory_position_controller:\n  ros__parameters:\n"
        "    constraints:\n      goal_time: 2.0\n"
    )
    merged = load_controllers([RRBOT_JTC, nested]).controllers[0].params["constraints"]
    assert merged == {"stopped_velocity_tolerance": 0.01, "goal_time": 2.0}


def test_session_runs_example_1_with_controllers_args() -> None:
    """The demo arm's joint1/joint2 stand in for RRBot's: the file, its substitution and the
    controller manager's listing end to end."""
    with (
        Session("demo", controllers=RRBOT, controllers_args={"joint_prefix": "joint"}) as session,
        connect(session.url) as client,
    ):
        listing = client.call_service("/controller_manager/list_controllers")["controller"]
        assert {c["name"]: c["type"] for c in listing} == {
            "joint_state_broadcaster": "joint_state_broadcaster/JointStateBroadcaster",
            "forward_position_controller": "forward_command_controller/ForwardCommandController",
        }
    with pytest.raises(ControllersConfigError, match=r"\$\(var joint_prefix\) has no value"):
        Session("demo", controllers=RRBOT)


@pytest.mark.harness(
    robot="demo",
    controllers=[str(RRBOT), str(RRBOT_JTC)],
    controllers_args={"joint_prefix": "joint"},
)
def test_marker_takes_several_files_and_controllers_args(harness_session: Session) -> None:
    with connect(harness_session.url) as client:
        listing = client.call_service("/controller_manager/list_controllers")["controller"]
        assert [c["name"] for c in listing] == [
            "joint_state_broadcaster",
            "forward_position_controller",
            "joint_trajectory_position_controller",
        ]


def test_scenario_controllers_list_and_args(tmp_path: Path) -> None:
    scenario = Scenario.from_mapping(
        {
            "robots": [{"robot": "demo"}],
            "controllers": [str(RRBOT), str(RRBOT_JTC)],
            "controllers_args": {"joint_prefix": "joint"},
        },
        base_dir=tmp_path,
    )
    assert scenario.controllers is not None
    assert scenario.controllers.controllers[1].params["joints"] == ["joint1", "joint2"]
    with pytest.raises(Exception, match=r"\$\(var joint_prefix\) has no value"):
        Scenario.from_mapping(
            {"robots": [{"robot": "demo"}], "controllers": str(RRBOT)}, base_dir=tmp_path
        )


def test_cli_missing_controllers_arg_is_one_line() -> None:
    command = [sys.executable, "-m", "harness", "serve", "--port", "0"]
    command += ["--controllers", str(RRBOT), "--controllers", str(RRBOT_JTC)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "$(var joint_prefix) has no value" in lines[0]
    assert str(RRBOT) in lines[0]
    bad = subprocess.run(
        [*command, "--controllers-arg", "joint_prefix=joint"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert bad.returncode == 2
    assert "is not NAME:=VALUE" in bad.stderr
