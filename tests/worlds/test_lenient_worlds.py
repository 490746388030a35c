"""Lenient worlds: a static model's inertia is never judged, a dynamic model's bad inertia is
repaired like a robot's, MuJoCo's rounding never refuses what the reader accepted (the
TurtleBot3 burger's thin-disc wheels), a compile error blames strict only when asked; and the
scenario's timestep defaults to the world's ``<max_step_size>``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from harness.models import RobotSpec, load_robot, load_world
from harness.models.errors import CompileError, ModelWarning
from harness.models.sdf import SdfInertiaError, read_sdf
from harness.models.sdf.worldfile import load_world_file
from harness.scenario.errors import ScenarioError
from harness.scenario.scenario import Scenario
from harness.scenario.world import effective_timestep, scene_for

TB3 = Path(__file__).resolve().parents[1] / "data" / "worlds" / "turtlebot3"
BURGER = TB3 / "models" / "turtlebot3_burger" / "model.sdf"
WORLD = TB3 / "worlds" / "turtlebot3_world.world"

# the burger's wheel: a thin disc, A + B = C exactly, under an rpy -1.57 inertial pose
WHEEL = """<?xml version="1.0"?><sdf version="1.8"><model name="disc">
  <link name="base"><inertial><mass>1</mass><inertia><ixx>0.01</ixx><iyy>0.01</iyy>
    <izz>0.01</izz></inertia></inertial>
    <collision name="c"><geometry><box><size>0.1 0.1 0.1</size></box></geometry></collision>
  </link>
  <link name="wheel"><inertial><pose>0 0.08 0.023 -1.57 0 0</pose><mass>0.1</mass>
    <inertia><ixx>5.445e-05</ixx><ixy>0</ixy><ixz>0</ixz><iyy>5.445e-05</iyy><iyz>0</iyz>
    <izz>1.089e-04</izz></inertia></inertial>
    <collision name="c"><pose>0 0.08 0.023 -1.57 0 0</pose><geometry><cylinder>
    <radius>0.033</radius><length>0.018</length></cylinder></geometry></collision>
  </link>
  <joint name="axle" type="revolute"><parent>base</parent><child>wheel</child>
    <pose>0 0.08 0.023 -1.57 0 0</pose><axis><xyz>0 0 1</xyz></axis></joint>
</model></sdf>"""


WHEEL_URDF = """<robot name="disc">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="wheel"><inertial><origin rpy="-1.57 0 0"/><mass value="0.1"/>
    <inertia ixx="5.445e-05" iyy="5.445e-05" izz="1.089e-04" ixy="0" ixz="0" iyz="0"/>
    </inertial><collision><origin rpy="-1.57 0 0"/><geometry>
    <cylinder radius="0.033" length="0.018"/></geometry></collision></link>
  <joint name="axle" type="continuous"><parent link="base"/><child link="wheel"/>
    <origin xyz="0 0.08 0.023" rpy="-1.57 0 0"/><axis xyz="0 0 1"/></joint>
</robot>"""


@pytest.mark.parametrize("strict", [False, True])
@pytest.mark.parametrize("kind", ["sdf", "urdf"])
def test_a_thin_disc_wheel_that_passes_the_check_compiles(
    tmp_path: Path, strict: bool, kind: str
) -> None:
    path = tmp_path / f"disc.{kind}"
    path.write_text(WHEEL if kind == "sdf" else WHEEL_URDF)
    if kind == "sdf":
        read_sdf(path, strict=True)  # the reader's check accepts it
    # a URDF's is not balanced to the mean of its moments either (MuJoCo's repair)
    model = load_robot(path, strict=strict).model
    body = model.body("wheel").id
    moments = sorted(float(m) for m in model.body_inertia[body])
    assert moments == pytest.approx([5.445e-05, 5.445e-05, 1.089e-04], rel=1e-8)
    assert moments[0] + moments[1] >= moments[2]


def test_the_finding_command_check_model_on_the_burger_succeeds() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "harness", "check-model", str(BURGER)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr + done.stdout
    assert "strict" not in done.stderr


BAD = """<?xml version="1.0"?><sdf version="1.8"><world name="w">
  <model name="{name}">{static}<pose>0 0 1 0 0 0</pose><link name="link"><inertial>
    <mass>1</mass><inertia><ixx>0.001</ixx><iyy>0.001</iyy><izz>1</izz></inertia></inertial>
    <collision name="c"><geometry><box><size>0.2 0.2 0.2</size></box></geometry></collision>
  </link></model></world></sdf>"""


def test_a_static_models_inertia_is_never_judged(tmp_path: Path) -> None:
    world = tmp_path / "w.sdf"
    world.write_text(BAD.format(name="shelf", static="<static>true</static>"))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not even a warning
        model = load_world_file(world).spec.compile()
    assert model.body("shelf::link").id > 0


def test_a_dynamic_models_bad_inertia_is_repaired_with_the_robots_note(tmp_path: Path) -> None:
    world = tmp_path / "w.sdf"
    world.write_text(BAD.format(name="crate", static=""))
    with pytest.warns(ModelWarning, match=r"invalid inertia .*repaired to principal moments"):
        model = load_world_file(world).spec.compile()
    moments = sorted(float(m) for m in model.body_inertia[model.body("crate::link").id])
    assert moments[0] + moments[1] >= moments[2]
    # the same file as a robot, strict: refused by the reader, naming strict's opposite
    robot = tmp_path / "crate.sdf"
    robot.write_text(
        BAD.format(name="crate", static="").replace('<world name="w">', "").replace("</world>", "")
    )
    with pytest.raises(SdfInertiaError, match="triangle inequality"):
        read_sdf(robot, strict=True)


def test_a_compile_error_blames_strict_only_when_strict_was_asked() -> None:
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="b")
    body.add_freejoint()
    body.explicitinertial = True
    body.mass = 1.0
    body.inertia = [0.001, 0.001, 1.0]
    from harness.models.build.compiler import compile_spec

    with pytest.raises(CompileError) as lenient:
        compile_spec(spec.copy(), "x.sdf")
    assert "strict" not in str(lenient.value)
    assert "triangle inequality" in str(lenient.value)
    with pytest.raises(CompileError, match="without strict=True"):
        compile_spec(spec.copy(), "x.sdf", strict=True)


def _scenario(tmp_path: Path, **extra: object) -> Scenario:
    data = {
        "name": "tb3",
        "robots": [{"robot": str(BURGER)}],
        "environment": {"map": str(WORLD)},
        **extra,
    }
    return Scenario.from_mapping(data, base_dir=tmp_path)


def test_the_scenario_timestep_defaults_to_the_worlds_max_step_size(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(TB3 / "models"))
    monkeypatch.setenv("HOME", str(tmp_path))
    scenario = _scenario(tmp_path)
    assert effective_timestep(scenario) == 0.001
    assert scene_for(scenario, tmp_path / "out") == WORLD  # the world as it is: no abort
    world = load_world([RobotSpec(BURGER, pose=[-2.0, -0.5, 0.0])], scene=WORLD)
    assert world.model.opt.timestep == 0.001
    with pytest.raises(ScenarioError) as caught:
        scene_for(_scenario(tmp_path, timestep=0.002), tmp_path / "out")
    text = str(caught.value)
    assert "0.002" in text
    assert "0.001" in text
    assert "\n" not in text.strip()
