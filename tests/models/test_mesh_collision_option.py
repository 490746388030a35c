"""``mesh_collision`` spelled once (Python, marker, scenario file, ``harness serve`` and
``check-model``), recorded in the metadata, and the decomposition attached to the recording so
that a rebuild never decomposes again (issue 33)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

from harness.models.build import decompose as decompose_module
from harness.models.build.decompose import MESH_COLLISION_MODES
from harness.models.check._cli import add_arguments as check_arguments
from harness.plugin.markers import parse_load_options
from harness.recording import Recording
from harness.replay.source import rebuild_run
from harness.scenario import Scenario, ScenarioError
from harness.scenario._validation import schema
from harness.session import Session
from harness.session._cli import add_arguments as serve_arguments
from harness.session.options import SESSION_KEYWORDS
from harness.vocabulary import MESH_COLLISION_MODES as VOCABULARY

from .test_mesh_decomposition import _wall, _wall_contacts


def _choices(add: object, dest: str) -> tuple[str, ...] | None:
    parser = argparse.ArgumentParser()
    add(parser)  # type: ignore[operator]
    for action in parser._actions:
        if action.dest == dest:
            return tuple(action.choices) if action.choices is not None else ()
    return None


@pytest.fixture
def arena(tmp_path: Path) -> Path:
    _wall().export(tmp_path / "wall.stl")
    (tmp_path / "arena.xml").write_text(
        '<mujoco><asset><mesh name="wall" file="wall.stl"/></asset><worldbody>'
        '<geom name="floor" type="plane" size="5 5 0.1"/>'
        '<geom name="wall" type="mesh" mesh="wall"/></worldbody></mujoco>'
    )
    (tmp_path / "arena.sdf").write_text(
        '<sdf version="1.9"><world name="arena"><model name="arena"><static>true</static>'
        '<link name="wall"><collision name="c"><geometry><mesh><uri>wall.stl</uri></mesh>'
        "</geometry></collision></link></model></world></sdf>"
    )
    (tmp_path / "cage.urdf").write_text(
        '<robot name="cage"><link name="cage"><inertial><mass value="10"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<collision><geometry><mesh filename="wall.stl"/></geometry></collision></link></robot>'
    )
    (tmp_path / "box.xml").write_text(
        '<mujoco model="box"><worldbody><body name="base" pos="0.5 0.3 0.1"><freejoint/>'
        '<geom name="shell" type="box" size=".1 .1 .1" mass="1"/></body></worldbody></mujoco>'
    )
    return tmp_path


def test_one_spelling_in_python_schema_cli_and_marker() -> None:
    assert VOCABULARY == MESH_COLLISION_MODES == ("decompose", "hull")
    environment = schema("scenario")["properties"]["environment"]["properties"]
    assert tuple(environment["mesh_collision"]["enum"]) == VOCABULARY
    for add in (serve_arguments, check_arguments):
        assert _choices(add, "mesh_collision") == VOCABULARY
    assert "mesh_collision" in SESSION_KEYWORDS  # Session keyword and marker key
    opts = {"mesh_collision": "hull"}
    parse_load_options(opts, "test")
    assert opts["mesh_collision"] == "hull"
    with pytest.raises(pytest.fail.Exception, match="unknown mesh_collision 'convex'"):
        parse_load_options({"mesh_collision": "convex"}, "test")


def test_scenario_file_chooses_hull(arena: Path) -> None:
    from harness.scenario.world import build_world

    text = (
        "name: arena\nenvironment: {map: arena.xml, mesh_collision: hull}\n"
        "robots:\n  - {robot: box.xml}\n"
    )
    (arena / "s.yaml").write_text(text)
    scenario = Scenario.load(arena / "s.yaml")
    assert scenario.environment.mesh_collision == "hull"
    with pytest.warns(UserWarning, match="contact"):
        world = build_world(scenario, arena)
    assert world.mesh_collision == "hull"
    (arena / "bad.yaml").write_text(text.replace("hull", "convex"))
    with pytest.raises(ScenarioError, match=r"environment\.mesh_collision: .convex. is not one of"):
        Scenario.load(arena / "bad.yaml")


def test_recording_carries_the_pieces_and_replay_never_decomposes(
    arena: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HARNESS_CACHE_DIR", str(tmp_path / "cache-recording"))
    path = tmp_path / "run.mcap"
    # a robot's concave collision mesh (the world's meshes are attached once worlds are
    # portable: the same mechanism carries the pieces)
    with Session(arena / "cage.urdf", record_to=path, controllers=False) as session:
        recorded = session.model
        assert any("#" in recorded.mesh(m).name for m in range(recorded.nmesh))
        session.step(5)
    rec = Recording(path)
    assert rec.metadata["mesh_collision"] == "decompose"
    pieces = [n for n in rec.attachment_names if n.startswith("source/decomposition/")]
    assert len(pieces) == 1

    def refuse(*args: object) -> object:
        raise AssertionError("decomposed again")

    # another machine: an empty cache, and CoACD must not run
    monkeypatch.setenv("HARNESS_CACHE_DIR", str(tmp_path / "cache-replay"))
    monkeypatch.setattr(decompose_module, "_run_coacd", refuse)
    rebuilt = rebuild_run(rec)
    assert rebuilt.model.ngeom == recorded.ngeom
    assert np.array_equal(rebuilt.model.mesh_vert, recorded.mesh_vert)
    assert not (tmp_path / "cache-replay").exists()


def test_session_hull_records_hull(arena: Path, tmp_path: Path) -> None:
    path = tmp_path / "hull.mcap"
    with (
        pytest.warns(UserWarning, match="contact"),
        Session(
            arena / "box.xml",
            scene=arena / "arena.sdf",
            mesh_collision="hull",
            controllers=False,
        ) as session,
    ):
        assert _wall_contacts(session.model, "base")  # inside the hull
    with Session(
        arena / "cage.urdf", record_to=path, mesh_collision="hull", controllers=False
    ) as session:
        sha = session.robot.sha256
    rec = Recording(path)
    assert rec.metadata["mesh_collision"] == "hull"
    assert not [n for n in rec.attachment_names if n.startswith("source/decomposition/")]
    rebuilt = rebuild_run(rec)
    assert rebuilt.sha256 == sha
    assert not any("#" in rebuilt.model.mesh(m).name for m in range(rebuilt.model.nmesh))
