"""Workspaces as ROS developers have them: a ``colcon build --symlink-install`` tree (the
install folder's files are links into ``src/``) loads, a link out of the workspace is still
refused, and packages are found by the ``<name>`` their ``package.xml`` declares under
``ROS_PACKAGE_PATH`` and ``AMENT_PREFIX_PATH``, as rospack and ament find them."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest

from harness.errors import ModelError
from harness.models import load_robot
from harness.models.errors import ResolveError, UnknownPackageError
from harness.models.files.resolve import find_package, resolve_uri

INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)


def _stl(path: Path) -> None:
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + body)


def _package(folder: Path, name: str) -> Path:
    """A source package ``name`` in ``folder``: package.xml, urdf/x.urdf, meshes/m.stl."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(
        f'<?xml version="1.0"?>\n<package format="3">\n  <name>{name}</name>\n</package>\n'
    )
    _stl(folder / "meshes" / "m.stl")
    (folder / "urdf").mkdir(exist_ok=True)
    (folder / "urdf" / "x.urdf").write_text(
        f'<robot name="r"><link name="base">{INERTIAL}<collision><geometry>'
        f'<mesh filename="package://{name}/meshes/m.stl"/></geometry></collision></link></robot>'
    )
    return folder


def _symlink_install(ws: Path, name: str) -> Path:
    """``ws`` built with ``colcon build --symlink-install``: src/<name> holds the package and
    install/<name>/share/<name> holds real folders whose files are relative links into src/,
    as colcon makes them; returns the share folder."""
    _package(ws / "src" / name, name)
    install = ws / "install"
    share = install / name / "share" / name
    for rel in ("package.xml", "urdf/x.urdf", "meshes/m.stl"):
        link = share / rel
        link.parent.mkdir(parents=True, exist_ok=True)
        depth = len(link.relative_to(ws).parts) - 1
        link.symlink_to(Path(*[".."] * depth, "src", name, rel))
    (install / ".colcon_install_layout").write_text("isolated\n")
    (install / "COLCON_IGNORE").write_text("")
    return share


@pytest.fixture
def clean_env(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    for var in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"):
        monkeypatch.delenv(var, raising=False)
    return monkeypatch


def test_symlink_install_workspace_loads(tmp_path: Path, clean_env: pytest.MonkeyPatch) -> None:
    share = _symlink_install(tmp_path / "ws", "my_robot")
    assert (share / "urdf" / "x.urdf").is_symlink()
    clean_env.setenv("AMENT_PREFIX_PATH", str(tmp_path / "ws" / "install" / "my_robot"))
    mesh = resolve_uri("package://my_robot/meshes/m.stl", base_dir=tmp_path, what="mesh")
    assert mesh == share / "meshes" / "m.stl"
    robot = load_robot(resolve_uri("package://my_robot/urdf/x.urdf", base_dir=tmp_path))
    assert robot.model.nmesh == 1


def test_a_link_out_of_the_workspace_is_refused(
    tmp_path: Path, clean_env: pytest.MonkeyPatch
) -> None:
    share = _symlink_install(tmp_path / "ws", "my_robot")
    _stl(tmp_path / "secret" / "key.stl")
    (share / "meshes" / "key.stl").symlink_to(tmp_path / "secret" / "key.stl")
    clean_env.setenv("AMENT_PREFIX_PATH", str(tmp_path / "ws" / "install" / "my_robot"))
    with pytest.raises(ResolveError) as info:
        resolve_uri("package://my_robot/meshes/key.stl", base_dir=tmp_path, what="mesh")
    text = str(info.value)
    assert "\n" not in text
    assert "escapes package 'my_robot'" in text
    assert "its workspace" in text
    assert str(tmp_path / "secret" / "key.stl") in text
    # `..` out of the share folder is refused before any link is looked at
    with pytest.raises(ResolveError, match="escapes package 'my_robot'"):
        resolve_uri("package://my_robot/../../../../src/my_robot/meshes/m.stl", base_dir=tmp_path)


def test_links_into_src_without_a_colcon_install_are_still_refused(tmp_path: Path) -> None:
    """Only an ``install`` folder colcon made widens the confinement to its workspace."""
    share = _symlink_install(tmp_path / "ws", "my_robot")
    for marker in (".colcon_install_layout", "COLCON_IGNORE"):
        (tmp_path / "ws" / "install" / marker).unlink()
    with pytest.raises(ResolveError, match="escapes package 'my_robot'"):
        resolve_uri("package://my_robot/meshes/m.stl", base_dir=share, packages={"my_robot": share})


def test_ros_package_path_is_crawled_by_package_xml_name(
    tmp_path: Path, clean_env: pytest.MonkeyPatch
) -> None:
    """As moveit_resources lays them out: folder panda_description, package
    moveit_resources_panda_description."""
    root = tmp_path / "src"
    _package(root / "moveit_resources" / "panda_description", "moveit_resources_panda_description")
    _package(root / "moveit_resources" / "fanuc_description", "moveit_resources_fanuc_description")
    (root / "ignored").mkdir()
    (root / "ignored" / "COLCON_IGNORE").write_text("")
    _package(root / "ignored" / "hidden_pkg", "hidden_pkg")
    clean_env.setenv("ROS_PACKAGE_PATH", os.pathsep.join([str(tmp_path / "none"), str(root)]))
    found = find_package("moveit_resources_panda_description")
    assert found == root / "moveit_resources" / "panda_description"
    urdf = resolve_uri(
        "package://moveit_resources_fanuc_description/urdf/x.urdf", base_dir=tmp_path / "none"
    )
    assert load_robot(urdf).model.nmesh == 1
    with pytest.raises(UnknownPackageError, match="unknown package 'hidden_pkg'"):
        find_package("hidden_pkg")
    # a folder named like the package whose package.xml declares another name is not it
    _package(root / "panda_description", "someone_else")
    with pytest.raises(UnknownPackageError, match="unknown package 'panda_description'"):
        find_package("panda_description")


def test_ament_prefix_share_by_name(tmp_path: Path, clean_env: pytest.MonkeyPatch) -> None:
    prefix = tmp_path / "opt" / "ros"
    _package(prefix / "share" / "ur_description", "ur_description")
    clean_env.setenv("AMENT_PREFIX_PATH", str(prefix))
    assert find_package("ur_description") == prefix / "share" / "ur_description"
    path = resolve_uri("package://ur_description/urdf/x.urdf", base_dir=tmp_path)
    assert load_robot(path).model.nmesh == 1


def test_a_rebuild_from_a_recording_does_not_search_the_environment(
    tmp_path: Path, clean_env: pytest.MonkeyPatch
) -> None:
    from harness.models.files.confine import confined_to

    root = tmp_path / "src"
    _package(root / "folder", "crawled_pkg")
    clean_env.setenv("ROS_PACKAGE_PATH", str(root))
    assert find_package("crawled_pkg") == root / "folder"
    attachments = tmp_path / "recording"
    attachments.mkdir()
    with confined_to(attachments), pytest.raises(ModelError, match="not among the recording"):
        find_package("crawled_pkg")
