"""package://, model://, file:// and relative references; DAE conversion into the cache."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from harness.models import load_robot
from harness.models.errors import ResolveError, UnknownPackageError
from harness.models.files.meshes import mesh_cache_dir, prepare_mesh
from harness.models.files.resolve import resolve_uri


@pytest.fixture
def workspace(tmp_path, data_dir) -> Path:
    """tmp/ws/src/pkg_demo (package.xml name: renamed_pkg) with meshes/tetra.stl."""
    pkg = tmp_path / "ws" / "src" / "pkg_demo"
    shutil.copytree(data_dir / "pkg_demo", pkg)
    return pkg


def _robot(pkg: Path, package_ref: str, mesh_ref: str) -> Path:
    template = (pkg / "urdf" / "meshy.urdf").read_text()
    path = pkg / "urdf" / "robot.urdf"
    path.write_text(template.replace("PKG", package_ref).replace("MESH", mesh_ref))
    return path


def test_search_order_map_env_walk_up(workspace, tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    base = workspace / "urdf"
    uri = "package://pkg_demo/meshes/tetra.stl"
    # walking up: a folder named like the package
    assert resolve_uri(uri, base_dir=base) == workspace / "meshes/tetra.stl"
    # walking up: a folder whose package.xml declares the name
    found = resolve_uri("package://renamed_pkg/meshes/tetra.stl", base_dir=base)
    assert found.resolve() == (workspace / "meshes/tetra.stl").resolve()
    # ROS_PACKAGE_PATH before walking up
    other = tmp_path / "other" / "pkg_demo" / "meshes"
    other.mkdir(parents=True)
    (other / "tetra.stl").write_bytes((workspace / "meshes/tetra.stl").read_bytes())
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "other"))
    assert resolve_uri(uri, base_dir=base) == other / "tetra.stl"
    # the explicit map first
    assert resolve_uri(uri, base_dir=base, packages={"pkg_demo": workspace}) == (
        workspace / "meshes/tetra.stl"
    )
    # package:///name (three slashes) is tolerated
    assert resolve_uri("package:///pkg_demo/meshes/tetra.stl", base_dir=base) == (
        other / "tetra.stl"
    )


def test_file_relative_and_model_uris(workspace, tmp_path, monkeypatch):
    base = workspace / "urdf"
    mesh = workspace / "meshes/tetra.stl"
    assert resolve_uri(f"file://{mesh}", base_dir=base) == mesh
    assert resolve_uri("../meshes/tetra.stl", base_dir=base) == base / "../meshes/tetra.stl"
    assert resolve_uri(str(mesh), base_dir=tmp_path) == mesh
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(workspace.parent))
    assert resolve_uri("model://pkg_demo/meshes/tetra.stl", base_dir=tmp_path) == mesh
    with pytest.raises(UnknownPackageError, match="unknown model 'ghost'"):
        resolve_uri("model://ghost/x.stl", base_dir=tmp_path)
    with pytest.raises(ResolveError, match="unsupported URI scheme"):
        resolve_uri("http://example.com/x.stl", base_dir=tmp_path)


def test_urdf_with_package_and_relative_meshes_compiles(workspace, tmp_path, mesh_cache):
    path = _robot(workspace, "renamed_pkg", "../meshes/tetra.stl")
    loaded = load_robot(path, cache_dir=mesh_cache)
    m = loaded.model
    # the same (ASCII STL, so converted) file through two references: one mesh, two geoms
    assert m.nmesh == 1
    assert Path(m.mesh(0).name).name != "tetra"
    mesh_geoms = [g for g in range(m.ngeom) if m.geom_dataid[g] == 0]
    assert sorted(m.body(int(m.geom_bodyid[g])).name for g in mesh_geoms) == ["arm", "base"]


def test_dae_is_converted_once_into_a_content_hashed_cache(robots, tmp_path, monkeypatch):
    dae = robots / "panda_description/meshes/visual/link0.dae"
    monkeypatch.setenv("HARNESS_CACHE_DIR", str(tmp_path / "cache"))
    assert mesh_cache_dir() == tmp_path / "cache"
    first = prepare_mesh(dae)
    assert first.parent == tmp_path / "cache"
    assert first.suffix == ".obj"
    assert first.read_text().count("\nf ") > 100
    stamp = first.stat().st_mtime_ns
    copy = tmp_path / "renamed.dae"
    shutil.copy(dae, copy)
    again = prepare_mesh(copy)
    assert again.name.split("-")[1] == first.name.split("-")[1]  # same content, same hash
    assert prepare_mesh(dae) == first
    assert first.stat().st_mtime_ns == stamp
    stl = robots / "panda_description/meshes/collision/link0.stl"
    assert prepare_mesh(stl) == stl


@pytest.mark.slow
def test_visual_dae_meshes_load_with_visuals(robots, mesh_cache):
    with_visuals = load_robot(
        robots / "panda_description/urdf/panda.urdf", visuals=True, cache_dir=mesh_cache
    )
    without = load_robot(robots / "panda_description/urdf/panda.urdf", cache_dir=mesh_cache)
    assert with_visuals.model.ngeom > without.model.ngeom
    assert any(p.suffix == ".obj" for p in Path(mesh_cache).iterdir())
