"""``<include>`` and model nesting as Gazebo resolves them (issue 33): ``<model>`` wrappers
with ``<static>`` and ``<pose>``, nested models, ``<include>`` inside a model, an include's own
``<name>``/``<pose>``/``<static>``, a Gazebo Classic ``<state>``, and ``<heightmap>`` refused
in one line."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness.errors import ModelError
from harness.models.sdf.worldfile import load_world_file

BOX_MODEL = """<?xml version="1.0"?>
<sdf version="1.7"><model name="crate"><static>{static}</static>
  <link name="body"><pose>0.1 0 0.2 0 0 0</pose>
    <inertial><mass>1</mass><inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz></inertia></inertial>
    <collision name="c"><geometry><box><size>0.2 0.2 0.2</size></box></geometry></collision>
  </link></model></sdf>
"""


def _world(tmp_path: Path, body: str, *, static: str = "false", version: str = "1.9") -> Path:
    folder = tmp_path / "models" / "crate"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "model.config").write_text(
        '<model><name>crate</name><sdf version="1.7">model.sdf</sdf></model>'
    )
    (folder / "model.sdf").write_text(BOX_MODEL.format(static=static))
    path = tmp_path / "w.world"
    path.write_text(
        f'<?xml version="1.0"?><sdf version="{version}"><world name="w">{body}</world></sdf>'
    )
    return path


@pytest.fixture(autouse=True)
def _path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "models"))


def _compiled(path: Path) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = load_world_file(path).spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _free(model: mujoco.MjModel) -> list[str]:
    return [
        model.joint(j).name
        for j in range(model.njnt)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]


def test_model_wrapper_static_and_pose_around_an_include(tmp_path: Path) -> None:
    """The wrapper's pose composes with the include's, its <static> welds the included
    model (as turtlebot3_world.world wraps model://turtlebot3_world)."""
    path = _world(
        tmp_path,
        '<model name="wrap"><static>true</static><pose>1 2 0 0 0 1.5707963267948966</pose>'
        "<include><uri>model://crate</uri><pose>0.5 0 0 0 0 0</pose></include></model>",
    )
    model, data = _compiled(path)
    body = model.body("wrap::crate::body")
    # wrapper (1, 2, yaw 90) * include (0.5, 0, 0) * link (0.1, 0, 0.2)
    np.testing.assert_allclose(data.xpos[body.id], [1.0, 2.6, 0.2], atol=1e-9)
    assert _free(model) == []


def test_nested_models_and_an_include_inside_a_model_with_overrides(tmp_path: Path) -> None:
    """A model inside a model, and an include inside a model with its own <name>, <pose> and
    <static> (false here although the file says true: the crate can be pushed)."""
    path = _world(
        tmp_path,
        '<model name="room"><static>false</static><pose>0 0 0 0 0 0</pose>'
        '<model name="shelf"><static>true</static><link name="board">'
        '<collision name="c"><pose>0 0 1 0 0 0</pose><geometry><box><size>1 0.3 0.02</size>'
        "</box></geometry></collision></link></model>"
        "<include><uri>model://crate</uri><name>box7</name><pose>3 0 0 0 0 0</pose>"
        "<static>false</static></include></model>",
        static="true",
    )
    model, data = _compiled(path)
    assert model.body("room::shelf::board").id > 0
    np.testing.assert_allclose(data.xpos[model.body("room::box7::body").id], [3.1, 0, 0.2])
    assert _free(model) == ["room::box7::body::__free__"]


def test_a_classic_worlds_state_places_its_models(tmp_path: Path) -> None:
    """Gazebo Classic saves where models were moved in <state>: that pose wins over the
    include's."""
    path = _world(
        tmp_path,
        "<include><uri>model://crate</uri><pose>0 0 0 0 0 0</pose></include>"
        '<state world_name="w"><sim_time>3 0</sim_time><model name="crate">'
        "<pose>-1 4 0 0 0 0</pose><scale>1 1 1</scale></model></state>",
        version="1.6",
    )
    model, data = _compiled(path)
    np.testing.assert_allclose(data.xpos[model.body("crate::body").id], [-0.9, 4.0, 0.2])


def test_a_heightmap_is_refused_in_one_line(tmp_path: Path) -> None:
    path = _world(
        tmp_path,
        '<model name="terrain"><static>true</static><link name="l"><collision name="c">'
        "<geometry><heightmap><uri>file://terrain.png</uri><size>10 10 1</size></heightmap>"
        "</geometry></collision></link></model>",
    )
    with pytest.raises(ModelError) as caught:
        load_world_file(path)
    message = str(caught.value)
    assert "\n" not in message
    assert "heightmap" in message
    assert str(path) in message
