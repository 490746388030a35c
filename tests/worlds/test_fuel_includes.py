"""Includes as gz resolves them offline: Fuel URIs from a local Fuel cache (a fake one here:
Fuel is never downloaded), the stock Ground Plane and Sun, light-only includes, wrappers,
overrides, a Classic world's ``<state>``, heightmaps; on turtlebot3_simulations' own world."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from harness.models.sdf import SdfIncludeError, SdfStructureError, load_document
from harness.models.sdf.worldfile import load_world_file

TB3 = Path(__file__).resolve().parents[1] / "data" / "worlds" / "turtlebot3"
WORLD = TB3 / "worlds" / "turtlebot3_world.world"
MODELS = TB3 / "models"
FUEL = "https://fuel.gazebosim.org/1.0/OpenRobotics/models"


@pytest.fixture
def no_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty home and no cache variable: nothing cached anywhere."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    for variable in ("GZ_FUEL_CACHE_PATH", "IGN_FUEL_CACHE_PATH", "GZ_SIM_RESOURCE_PATH"):
        monkeypatch.delenv(variable, raising=False)
    return home


def _cached_model(folder: Path, model: str, size: float) -> None:
    """A model as gz caches it: ``model.config`` + ``model.sdf`` with one static box."""
    folder.mkdir(parents=True)
    (folder / "model.config").write_text(
        '<?xml version="1.0"?><model><name>x</name><sdf version="1.8">model.sdf</sdf></model>'
    )
    (folder / "model.sdf").write_text(
        f"""<?xml version="1.0"?><sdf version="1.8"><model name="{model}"><static>true</static>
        <link name="link"><collision name="c"><geometry><box><size>{size} {size} 0.1</size>
        </box></geometry></collision></link></model></sdf>"""
    )


def _body_names(model: mujoco.MjModel) -> set[str]:
    return {model.body(b).name for b in range(model.nbody)}


def test_turtlebot3_world_loads_with_the_stock_ground_plane_and_no_sun(no_cache: Path) -> None:
    world = load_world_file(WORLD, search_paths=[MODELS])
    model = world.spec.compile()
    bodies = _body_names(model)
    # the Fuel Ground Plane (stock copy), the wrapper around model://turtlebot3_world; no sun
    assert {"ground_plane::link", "turtlebot3_world::ros_symbol::symbol"} <= bodies
    assert not any("sun" in b for b in bodies)
    plane = model.geom("ground_plane::link/collision")
    assert model.geom_type[plane.id] == mujoco.mjtGeom.mjGEOM_PLANE
    # the wrapper's <static> holds: nothing of the world moves
    assert model.njnt == 0
    assert world.timestep == 0.001


def test_the_finding_command_inspect_model_succeeds(no_cache: Path) -> None:
    env = {**os.environ, "GZ_SIM_RESOURCE_PATH": str(MODELS)}
    done = subprocess.run(
        [sys.executable, "-m", "harness", "inspect-model", str(WORLD)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "ground_plane::link" in done.stdout
    assert "turtlebot3_world::ros_symbol::symbol" in done.stdout


def test_fuel_includes_come_from_the_local_cache_highest_version(
    tmp_path: Path, no_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = tmp_path / "cache"
    plane = cache / "fuel.gazebosim.org" / "openrobotics" / "models" / "ground plane"
    _cached_model(plane / "1", "ground_plane", 7.0)
    _cached_model(plane / "3", "ground_plane", 9.0)  # the highest version wins
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(cache))
    model = load_world_file(WORLD, search_paths=[MODELS]).spec.compile()
    box = model.geom("ground_plane::link/c")
    assert model.geom_size[box.id][0] == pytest.approx(4.5)


def test_a_fuel_version_the_old_host_and_the_default_cache_folder(
    tmp_path: Path, no_cache: Path
) -> None:
    # ~/.gz/fuel with the model under the new host; the URI names the old host, version 1
    plane = no_cache / ".gz" / "fuel" / "fuel.gazebosim.org" / "acme" / "models" / "crate"
    _cached_model(plane / "1", "crate", 2.0)
    _cached_model(plane / "2", "crate", 4.0)
    world = tmp_path / "w.sdf"
    world.write_text(
        """<?xml version="1.0"?><sdf version="1.8"><world name="w"><include>
        <uri>https://fuel.ignitionrobotics.org/1.0/ACME/models/Crate/1</uri></include>
        </world></sdf>"""
    )
    model = load_world_file(world).spec.compile()
    assert model.geom_size[model.geom("crate::link/c").id][0] == pytest.approx(1.0)


def test_a_missing_fuel_model_is_one_line_naming_the_uri_and_every_place(
    tmp_path: Path, no_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = tmp_path / "cache"
    cache.mkdir()
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(cache))
    world = tmp_path / "w.sdf"
    uri = f"{FUEL}/Construction Cone"
    world.write_text(
        f'<?xml version="1.0"?><sdf version="1.8"><world name="w"><include><uri>{uri}</uri>'
        "</include></world></sdf>"
    )
    with pytest.raises(SdfIncludeError) as caught:
        load_world_file(world)
    text = str(caught.value)
    assert "\n" not in text
    assert repr(uri) in text
    for root in (cache, no_cache / ".gz" / "fuel", no_cache / ".ignition" / "fuel"):
        assert (
            str(root / "fuel.gazebosim.org" / "openrobotics" / "models" / "construction cone")
            in text
        )
    assert "never downloaded" in text


@pytest.mark.parametrize("uri", ["model://sun", f"{FUEL}/Sun"])
def test_a_light_only_include_is_skipped_even_when_the_model_is_absent(
    tmp_path: Path, no_cache: Path, uri: str
) -> None:
    world = tmp_path / "w.sdf"
    world.write_text(
        f'<?xml version="1.0"?><sdf version="1.8"><world name="w"><include><uri>{uri}</uri>'
        '</include><model name="m"><static>true</static><link name="l"/></model></world></sdf>'
    )
    # load_document searches no bundled folder: the sun is nowhere, and still skipped
    document = load_document(world, search_paths=[tmp_path / "empty"])
    assert [c.name for c in document.root.children] == ["m"]
    assert [p.name for p in load_world_file(world).models] == ["m"]


def test_wrappers_nested_includes_and_include_overrides(tmp_path: Path, no_cache: Path) -> None:
    models = tmp_path / "models"
    _cached_model(models / "block", "block", 1.0)
    (models / "block" / "model.sdf").write_text(
        (models / "block" / "model.sdf").read_text().replace("<static>true</static>", "")
    )
    (models / "pair").mkdir()
    (models / "pair" / "model.sdf").write_text(
        """<?xml version="1.0"?><sdf version="1.8"><model name="pair">
        <include><uri>model://block</uri><name>left</name><pose>0 1 0 0 0 0</pose></include>
        <include><uri>model://block</uri><name>right</name><pose>0 -1 0 0 0 0</pose></include>
        </model></sdf>"""
    )
    world = tmp_path / "w.sdf"
    world.write_text(
        """<?xml version="1.0"?><sdf version="1.8"><world name="w">
        <model name="wrapped"><static>true</static><pose>5 0 0 0 0 0</pose>
          <include><uri>model://block</uri></include></model>
        <include><uri>model://block</uri><name>moved</name><pose>0 0 2 0 0 0</pose>
          <static>true</static></include>
        <include><uri>model://block</uri><name>free</name><pose>0 3 1 0 0 0</pose></include>
        <include><uri>model://pair</uri><pose>-5 0 0 0 0 0</pose></include>
        </world></sdf>"""
    )
    model = load_world_file(world, search_paths=[models]).spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    def at(body: str) -> list[float]:
        return [round(float(v), 9) for v in data.xpos[model.body(body).id]]

    assert at("wrapped::block::link") == [5.0, 0.0, 0.0]
    assert at("moved::link") == [0.0, 0.0, 2.0]
    assert at("free::link") == [0.0, 3.0, 1.0]
    assert at("pair::left::link") == [-5.0, 1.0, 0.0]
    assert at("pair::right::link") == [-5.0, -1.0, 0.0]
    joints = sorted(model.joint(j).name for j in range(model.njnt))
    # the wrapper's and the include's <static> weld; the others are free
    assert joints == [
        "free::link::__free__",
        "pair::left::link::__free__",
        "pair::right::link::__free__",
    ]


def test_a_classic_world_state_places_its_models(tmp_path: Path, no_cache: Path) -> None:
    world = tmp_path / "classic.world"
    world.write_text(
        """<?xml version="1.0"?><sdf version="1.6"><world name="default">
        <include><uri>model://ground_plane</uri></include>
        <include><uri>model://sun</uri></include>
        <model name="box"><static>true</static><pose>0 0 0.5 0 0 0</pose><link name="link">
          <collision name="c"><geometry><box><size>1 1 1</size></box></geometry></collision>
        </link></model>
        <state world_name="default"><sim_time>12 0</sim_time>
          <model name="box"><pose>2 -1 0.5 0 0 1.5708</pose><scale>1 1 1</scale>
            <link name="link"><pose>2 -1 0.5 0 0 1.5708</pose></link></model>
          <model name="ground_plane"><pose>0 0 0 0 0 0</pose></model>
        </state></world></sdf>"""
    )
    placed = {p.name: p.pose for p in load_world_file(world).models}
    assert placed["box"].xyz == pytest.approx((2.0, -1.0, 0.5))
    assert placed["ground_plane"].xyz == pytest.approx((0.0, 0.0, 0.0))


def test_a_heightmap_is_refused_in_one_line(tmp_path: Path, no_cache: Path) -> None:
    world = tmp_path / "terrain.world"
    world.write_text(
        """<?xml version="1.0"?><sdf version="1.6"><world name="default">
        <model name="terrain"><static>true</static><link name="link"><collision name="c">
        <geometry><heightmap><uri>file://terrain.png</uri><size>10 10 2</size></heightmap>
        </geometry></collision></link></model></world></sdf>"""
    )
    with pytest.raises(SdfStructureError) as caught:
        load_world_file(world)
    text = str(caught.value)
    assert "\n" not in text
    assert "terrain.world" in text
    assert "<heightmap> is not supported" in text


def test_a_mesh_named_by_a_fuel_file_uri_comes_from_the_cache(
    tmp_path: Path, no_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = tmp_path / "cache"
    folder = cache / "fuel.gazebosim.org" / "acme" / "models" / "rock" / "2"
    (folder / "meshes").mkdir(parents=True)
    (folder / "meshes" / "rock.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(cache))
    world = tmp_path / "w.sdf"
    world.write_text(
        """<?xml version="1.0"?><sdf version="1.8"><world name="w"><model name="rock">
        <static>true</static><link name="link"><collision name="c"><geometry><mesh><uri>
        https://fuel.gazebosim.org/1.0/ACME/models/Rock/tip/files/meshes/rock.obj
        </uri></mesh></geometry></collision></link></model></world></sdf>"""
    )
    model = load_world_file(world).spec.compile()
    assert model.nmesh == 1
    assert model.mesh_vertnum[0] == 4


def test_a_rebuild_from_a_recording_reads_no_fuel_cache(
    tmp_path: Path, no_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from harness.models.errors import OutsideReferenceError
    from harness.models.files.confine import confined_to
    from harness.models.files.fuel import STOCK_FOLDER, find_fuel_model, parse_fuel_uri

    cache = tmp_path / "cache"
    _cached_model(cache / "fuel.gazebosim.org" / "acme" / "models" / "crate" / "1", "crate", 1.0)
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(cache))
    crate = "https://fuel.gazebosim.org/1.0/ACME/models/Crate"
    plane = f"{FUEL}/Ground%20Plane"
    parsed_crate, parsed_plane = parse_fuel_uri(crate), parse_fuel_uri(plane)
    assert parsed_crate is not None
    assert parsed_plane is not None
    assert find_fuel_model(parsed_crate, crate).parent.name == "crate"
    recording = tmp_path / "recording"
    recording.mkdir()
    with confined_to(recording):
        assert find_fuel_model(parsed_plane, plane) == STOCK_FOLDER / "ground_plane"
        with pytest.raises(OutsideReferenceError, match="not among the recording's attachments"):
            find_fuel_model(parsed_crate, crate)
