"""MJCF file references are confined like ``package://`` ones: ``<include>``, meshes, textures,
height fields (and compiler directories) must stay in the model's folder (or the ROS package
it lies in); ``..``, absolute and symlink escapes are refused before MuJoCo opens anything,
with one ModelError line naming the file and element."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from harness.models import load_robot
from harness.models.errors import ResolveError
from harness.models.mjcf.files import check_mjcf_files

BODY = '<worldbody><body><geom size=".1"/></body></worldbody>'


def _stl(path: Path) -> Path:
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + body)
    return path


@pytest.fixture
def layout(tmp_path: Path) -> Path:
    """tmp/robot (the model's folder, meshes/ok.stl, parts.xml) and tmp/secret outside."""
    _stl(tmp_path / "robot" / "meshes" / "ok.stl")
    (tmp_path / "robot" / "parts.xml").write_text(f"<mujoco>{BODY}</mujoco>")
    _stl(tmp_path / "secret" / "key.stl")
    (tmp_path / "secret" / "inc.xml").write_text(f"<mujoco>{BODY}</mujoco>")
    (tmp_path / "secret" / "tex.png").write_bytes(b"\x89PNG")
    return tmp_path


def _model(layout: Path, inner: str, name: str = "m.xml") -> Path:
    path = layout / "robot" / name
    path.write_text(f"<mujoco>{inner}</mujoco>")
    return path


MESH = (
    '<asset><mesh name="m" file="{}"/></asset>'
    '<worldbody><body><geom type="mesh" mesh="m"/></body></worldbody>'
)
ESCAPES = {
    "include-dotdot": '<include file="../secret/inc.xml"/>',
    "include-absolute": '<include file="{secret}/inc.xml"/>',
    "mesh-dotdot": MESH.format("../secret/key.stl"),
    "mesh-absolute": MESH.format("{secret}/key.stl"),
    "meshdir": '<compiler meshdir="../secret"/>' + MESH.format("key.stl"),
    "texture": '<asset><texture name="t" type="2d" file="../secret/tex.png"/></asset>' + BODY,
    "cube-texture": '<asset><texture name="t" type="cube" fileright="{secret}/tex.png"/></asset>'
    + BODY,
    "hfield": '<asset><hfield name="h" file="../secret/tex.png"/></asset>' + BODY,
}


@pytest.mark.parametrize("inner", list(ESCAPES.values()), ids=list(ESCAPES))
def test_mjcf_references_cannot_leave_the_model_folder(layout: Path, inner: str) -> None:
    path = _model(layout, inner.format(secret=layout / "secret"))
    with pytest.raises(ResolveError, match="escapes the model's folder") as info:
        load_robot(path)
    message = str(info.value)
    assert str(path) in message
    assert "\n" not in message


def test_escape_inside_an_include_names_the_included_file(layout: Path) -> None:
    (layout / "robot" / "parts.xml").write_text(
        "<mujoco>" + MESH.format("../secret/key.stl") + "</mujoco>"
    )
    path = _model(layout, '<include file="parts.xml"/>')
    with pytest.raises(ResolveError, match=r"parts\.xml: line 1: <mesh") as info:
        load_robot(path)
    assert "escapes" in str(info.value)


def test_symlink_out_of_the_folder_is_refused(layout: Path) -> None:
    (layout / "robot" / "meshes" / "link.stl").symlink_to(layout / "secret" / "key.stl")
    path = _model(layout, '<compiler meshdir="meshes"/>' + MESH.format("link.stl"))
    with pytest.raises(ResolveError, match="escapes"):
        load_robot(path)


def test_references_inside_the_folder_and_its_package_load(layout: Path) -> None:
    ok = _model(
        layout, '<compiler meshdir="meshes"/><include file="parts.xml"/>' + MESH.format("ok.stl")
    )
    assert load_robot(ok).model.nmesh == 1
    # a model in pkg/mjcf/ may use pkg/meshes/ when pkg is a ROS package
    pkg = layout / "pkg"
    _stl(pkg / "meshes" / "p.stl")
    (pkg / "package.xml").write_text("<package><name>pkg</name></package>")
    (pkg / "mjcf").mkdir()
    inner = '<compiler meshdir="../meshes"/>' + MESH.format("p.stl")
    (pkg / "mjcf" / "r.xml").write_text(f"<mujoco>{inner}</mujoco>")
    check_mjcf_files(pkg / "mjcf" / "r.xml")
    assert load_robot(pkg / "mjcf" / "r.xml").model.nmesh == 1


def test_include_cycle_is_refused(layout: Path) -> None:
    path = _model(layout, '<include file="m.xml"/>')
    with pytest.raises(ResolveError, match="include cycle"):
        check_mjcf_files(path)


def test_a_compiler_folder_no_file_uses_is_not_a_reference(layout: Path) -> None:
    """A generated scene keeps an absolute meshdir back at its map's folder; recorded, it
    names a folder of another machine. Nothing is looked up in it unless a file asset is, so
    it loads; a mesh looked up through it is still refused."""
    elsewhere = layout / "secret"
    path = _model(layout, f'<compiler meshdir="{elsewhere}" texturedir="{elsewhere}"/>' + BODY)
    assert load_robot(path).model.nbody >= 2
    used = _model(layout, f'<compiler meshdir="{elsewhere}"/>' + MESH.format("key.stl"), "u.xml")
    with pytest.raises(ResolveError, match="escapes the model's folder"):
        load_robot(used)
