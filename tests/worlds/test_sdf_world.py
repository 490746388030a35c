"""SDF worlds as the map: includes, static and free models, physics, the MJCF twin, replay."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness import Session
from harness.models import load_robot
from harness.models.errors import ModelStructureError
from harness.models.sdf.worldfile import load_world_file
from harness.replay import verify

DATA = Path(__file__).resolve().parents[1] / "data" / "worlds"


def test_world_with_includes_static_and_free_models_loads() -> None:
    world = load_world_file(DATA / "room.world")
    model = world.spec.compile()
    bodies = {model.body(b).name for b in range(model.nbody)}
    assert {"ground_plane::link", "wall::link", "crate::body"} <= bodies
    free = [model.joint(j).name for j in range(model.njnt)]
    assert free == ["crate::body::__free__"]  # the wall is static, the crate is not
    assert world.timestep == 0.002
    assert world.gravity == (0.0, 0.0, -9.81)
    crate = model.geom("crate::body/collision")
    assert float(model.geom_friction[crate.id][0]) == 0.5  # <surface><friction><ode><mu>
    # the world, the bundled ground plane, the crate's model folder as model:// finds it
    assert sorted(world.sources) == [
        "scene/crate/model.config",
        "scene/crate/model.sdf",
        "scene/include/1/model.sdf",
        "scene/room.world",
    ]


def test_sdf_world_and_its_mjcf_twin_give_the_same_body_poses() -> None:
    sdf = load_world_file(DATA / "room.world").spec.compile()
    mjcf = mujoco.MjModel.from_xml_path(str(DATA / "room.xml"))
    datas = []
    for model in (sdf, mjcf):
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        datas.append(data)
    for body in ("wall::link", "crate::body"):
        a, b = sdf.body(body).id, mjcf.body(body).id
        np.testing.assert_allclose(datas[0].xpos[a], datas[1].xpos[b], atol=1e-9)
        np.testing.assert_allclose(datas[0].xquat[a], datas[1].xquat[b], atol=1e-9)


def test_a_free_model_of_the_world_can_be_pushed() -> None:
    loaded = load_robot("demo", scene=DATA / "room.world")
    model = loaded.model
    data = mujoco.MjData(model)
    joint = model.joint("crate::body::__free__")
    start = float(data.qpos[joint.qposadr[0]])
    force = np.zeros(6)
    force[0] = 20.0  # newtons along x, on the crate
    for _ in range(250):
        data.xfrc_applied[model.body("crate::body").id] = force
        mujoco.mj_step(model, data)
    assert float(data.qpos[joint.qposadr[0]]) - start > 0.05
    wall = model.body("wall::link").id
    assert model.body_weldid[wall] == 0  # the static wall did not move: welded to the world


def test_a_world_that_is_a_model_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ModelStructureError, match="not an SDF world"):
        load_world_file(DATA / "crate" / "model.sdf")


def test_a_recording_in_the_world_replays_after_the_world_files_are_deleted(
    tmp_path: Path,
) -> None:
    copy = tmp_path / "world"
    shutil.copytree(DATA, copy)
    path = tmp_path / "run.mcap"
    with Session("demo", scene=copy / "room.world", record_to=path) as session:
        session.step(100)
    shutil.rmtree(copy)
    report = verify(path)
    assert report.reproduced, report
    assert report.states_compared >= 100


def test_inspect_model_lists_every_model_of_a_world_scoped(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from harness.cli import main

    assert main(["inspect-model", str(DATA / "room.world"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    links = {link["name"]: link["pose"] for link in doc["links"]}
    assert set(links) == {"ground_plane::link", "wall::link", "crate::body"}
    assert links["wall::link"][:3] == [2.0, 0.0, 0.25]
    (joint,) = doc["joints"]
    assert (joint["name"], joint["parent"], joint["child"]) == (
        "crate::body::__free__",
        "world",
        "crate::body",
    )
    assert {"crate::__model__", "wall::__model__"} <= {f["name"] for f in doc["frames"]}
