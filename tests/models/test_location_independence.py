"""A compiled model depends on file contents only, never on where the files are installed.

The same robot (real Panda from example-robot-data, an SDF and an MJCF with meshes, a scene
with a mesh and a texture) is copied to two different folders and loaded with two different
mesh caches: the mjb bytes, the MJCF text and its sha256 must be identical, and neither may
name a folder.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import pytest

from harness.models import LoadedRobot, LoadedWorld, RobotSpec, load_robot, load_world
from harness.models.errors import ResolveError
from harness.models.files.assets import asset_name

MESH_ARM = Path(__file__).resolve().parents[1] / "data" / "models" / "mesh_arm"


def _assert_same_and_placeless(first: LoadedRobot, second: LoadedRobot, *roots: Path) -> None:
    assert first.mjb == second.mjb
    assert first.mjcf == second.mjcf
    assert first.sha256 == second.sha256
    for root in roots:
        assert str(root) not in first.mjcf
        assert str(root).encode() not in first.mjb
    names = bytes(first.model.paths).split(b"\0")
    assert [n for n in names if n], "the model has file assets"
    assert all(b"/" not in n for n in names), names


def _copy_panda(robots: Path, root: Path) -> Path:
    target = root / "example-robot-data" / "robots" / "panda_description"
    shutil.copytree(robots / "panda_description", target, ignore=shutil.ignore_patterns("visual"))
    return target / "urdf" / "panda.urdf"


def test_panda_compiles_identically_from_two_copies(robots, tmp_path):
    one, two = tmp_path / "one", tmp_path / "elsewhere" / "two"
    first = load_robot(_copy_panda(robots, one), cache_dir=one / "cache")
    second = load_robot(_copy_panda(robots, two), cache_dir=two / "cache")
    _assert_same_and_placeless(first, second, one, two, robots)
    installed = load_robot(robots / "panda_description/urdf/panda.urdf", cache_dir=tmp_path / "c")
    assert installed.mjb == first.mjb
    assert installed.sha256 == first.sha256
    assert first.model.nmesh == 9  # collision meshes of links 0-7 and the hand


def _copy_mesh_arm(root: Path) -> Path:
    target = root / "models" / "mesh_arm"
    shutil.copytree(MESH_ARM, target)
    return target


def test_sdf_with_converted_meshes_compiles_identically_from_two_copies(tmp_path):
    one, two = _copy_mesh_arm(tmp_path / "one"), _copy_mesh_arm(tmp_path / "b" / "two")
    first = load_robot(one / "model.sdf", cache_dir=tmp_path / "cache1")
    second = load_robot(two / "model.sdf", cache_dir=tmp_path / "cache2")
    _assert_same_and_placeless(first, second, tmp_path, MESH_ARM)
    files = sorted(bytes(first.model.paths).decode().split("\0"))[1:]
    # DAE and ASCII STL converted to OBJ, the binary STL used as is
    assert [Path(f).suffix for f in files] == [".obj", ".stl", ".obj"]
    assert [f.split("-")[0] for f in files] == ["base", "link", "tip"]
    cached = sorted(p.name for p in (tmp_path / "cache1").iterdir())
    conversions = [n for n in cached if not n.startswith("decompose-")]  # issue 33's pieces
    assert [name.split("-")[0] for name in conversions] == ["base", "tip"]  # the two conversions
    assert cached == sorted(p.name for p in (tmp_path / "cache2").iterdir())


def test_mjcf_robot_and_scene_files_compile_identically_from_two_copies(tmp_path):
    one, two = _copy_mesh_arm(tmp_path / "one"), _copy_mesh_arm(tmp_path / "b" / "two")
    first = load_robot(one / "mesh_arm.xml", scene=one / "scene.xml")
    second = load_robot(two / "mesh_arm.xml", scene=two / "scene.xml")
    _assert_same_and_placeless(first, second, tmp_path, MESH_ARM)
    assert first.model.ntex == 2  # the robot's texture (texturedir) and the scene's
    assert first.model.nmesh == 2  # the robot's link (meshdir) and the scene's obstacle
    alone = load_robot(one / "mesh_arm.xml")  # an MJCF robot as its own world
    assert load_robot(two / "mesh_arm.xml").mjb == alone.mjb


@pytest.mark.filterwarnings("ignore:Attaching a spec with an empty prefix")
def test_the_loaded_model_needs_no_file_any_more(tmp_path):
    folder = _copy_mesh_arm(tmp_path / "copy")
    loaded = load_robot(folder / "model.sdf", scene=folder / "scene.xml", cache_dir=tmp_path / "c")
    shutil.rmtree(folder)
    shutil.rmtree(tmp_path / "c")
    # the spec carries its files: it recompiles (as the scenario runner does) to the same model
    recompiled = loaded.spec.compile()
    assert recompiled.nmesh == loaded.model.nmesh == 4
    saved = tmp_path / "model.mjb"
    saved.write_bytes(loaded.mjb)
    replayed = mujoco.MjModel.from_binary_path(str(saved))
    assert replayed.nmeshvert == loaded.model.nmeshvert


def test_a_missing_mjcf_mesh_names_file_and_element(tmp_path):
    folder = _copy_mesh_arm(tmp_path / "copy")
    (folder / "meshes" / "link.stl").unlink()
    with pytest.raises(
        ResolveError,
        match=r'mesh_arm\.xml: <mesh name="link">: mesh not found: '
        r".*meshes/link\.stl.* \(from 'link\.stl'\)",
    ):
        load_robot(folder / "mesh_arm.xml")


def test_asset_names_follow_content_not_place():
    data = b"solid x\nendsolid x\n"
    name = asset_name("/opt/a/meshes/Link 0.STL", data)
    assert name == asset_name("relative/Link 0.STL", data)
    assert name.startswith("Link_0-")
    assert name.endswith(".stl")
    assert len(name.split("-")[1].split(".")[0]) == 16
    assert asset_name("/opt/a/meshes/Link 0.STL", data + b" ") != name


def _world(folder: Path, cache: Path) -> LoadedWorld:
    robots = [
        RobotSpec(folder / "model.sdf", namespace="sdf"),
        RobotSpec(folder / "mesh_arm.xml", namespace="mjcf", pose=[0.0, 0.5, 0.0]),
    ]
    return load_world(robots, scene=folder / "scene.xml", cache_dir=cache)


def test_a_world_of_namespaced_robots_compiles_identically_from_two_copies(tmp_path):
    one, two = _copy_mesh_arm(tmp_path / "one"), _copy_mesh_arm(tmp_path / "b" / "two")
    first, second = _world(one, tmp_path / "c1"), _world(two, tmp_path / "c2")
    assert first.mjb == second.mjb
    assert first.sha256 == second.sha256
    files = [f for f in bytes(first.model.paths).decode().split("\0") if f]
    # each robot's files under its prefix, the scene's unprefixed; no folder anywhere
    assert {f.split("/")[0] for f in files if "/" in f} == {"sdf", "mjcf"}
    assert str(tmp_path) not in first.mjcf
    assert str(tmp_path).encode() not in first.mjb
