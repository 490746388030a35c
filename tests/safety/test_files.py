"""Files from untrusted places: ``package://``/``model://`` references confined to their
package (no ``..``, absolute or symlink escapes), XML never expands entities (billion laughs,
external entities, also in COLLADA meshes and in UTF-16), and oversized model files are refused
before they are read. Every refusal is one ModelError line naming the file."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from harness.errors import ModelError
from harness.models import load_robot
from harness.models.errors import ResolveError, XMLError
from harness.models.files.meshes import prepare_mesh
from harness.models.files.resolve import resolve_uri
from harness.models.files.xmlsafe import MAX_XML_BYTES, parse_xml
from harness.models.sdf import read_sdf

INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)


def _stl(path: Path) -> Path:
    """A binary STL tetrahedron."""
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(faces)) + body)
    return path


def _urdf(path: Path, mesh_uri: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        f'<robot name="r"><link name="base">{INERTIAL}<collision><geometry>'
        f'<mesh filename="{mesh_uri}"/></geometry></collision></link></robot>'
    )
    return path


@pytest.fixture
def layout(tmp_path: Path) -> Path:
    """tmp/ws/pkg (a package with meshes/ok.stl and urdf/) and tmp/secret/key.stl outside."""
    _stl(tmp_path / "ws" / "pkg" / "meshes" / "ok.stl")
    (tmp_path / "ws" / "pkg" / "urdf").mkdir()
    _stl(tmp_path / "secret" / "key.stl")
    return tmp_path


ESCAPES = [
    "package://pkg/../../secret/key.stl",
    "package://pkg/meshes/../../../secret/key.stl",
    "package://pkg/%2e%2e/%2e%2e/secret/key.stl",
    "package://pkg//{root}/secret/key.stl",
    "package://../secret/key.stl",
    "package://./../secret/key.stl",
]


@pytest.mark.parametrize("uri", ESCAPES)
def test_package_references_cannot_leave_the_package(layout: Path, uri: str) -> None:
    pkg = layout / "ws" / "pkg"
    uri = uri.format(root=str(layout).lstrip("/"))
    with pytest.raises(ResolveError) as info:
        resolve_uri(uri, base_dir=pkg / "urdf", packages={"pkg": pkg}, what="mesh")
    assert "\n" not in str(info.value)
    assert "escapes package" in str(info.value) or "invalid package name" in str(info.value)


def test_model_references_cannot_leave_the_model(layout: Path) -> None:
    models = layout / "ws"
    with pytest.raises(ResolveError, match="escapes model 'pkg'"):
        resolve_uri("model://pkg/../../secret/key.stl", base_dir=layout, search_paths=[models])
    with pytest.raises(ResolveError, match="invalid model name"):
        resolve_uri("model://../secret/key.stl", base_dir=layout, search_paths=[models])


def test_symlink_out_of_the_package_is_refused(layout: Path) -> None:
    pkg = layout / "ws" / "pkg"
    (pkg / "meshes" / "sneaky.stl").symlink_to(layout / "secret" / "key.stl")
    (pkg / "meshes" / "inside.stl").symlink_to(pkg / "meshes" / "ok.stl")
    with pytest.raises(ResolveError, match="escapes package 'pkg'"):
        resolve_uri("package://pkg/meshes/sneaky.stl", base_dir=pkg, packages={"pkg": pkg})
    # a symlink that stays inside is fine, and so is the ordinary reference
    assert resolve_uri("package://pkg/meshes/inside.stl", base_dir=pkg, packages={"pkg": pkg})
    assert resolve_uri("package://pkg/meshes/ok.stl", base_dir=pkg, packages={"pkg": pkg})


def test_load_robot_refuses_an_escaping_mesh(layout: Path) -> None:
    pkg = layout / "ws" / "pkg"
    good = _urdf(pkg / "urdf" / "good.urdf", "package://pkg/meshes/ok.stl")
    assert load_robot(good, packages={"pkg": pkg}).model.nmesh == 1
    bad = _urdf(pkg / "urdf" / "bad.urdf", "package://pkg/../../secret/key.stl")
    with pytest.raises(ModelError, match="escapes package 'pkg'") as info:
        load_robot(bad, packages={"pkg": pkg})
    assert "bad.urdf" in str(info.value)


LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE lolz [\n<!ENTITY lol "lol">\n'
    + "".join(
        f'<!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n'
        for i in range(1, 10)
    )
    + ']>\n<robot name="&lol9;"/>'
)
EXTERNAL = (
    '<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
    '<robot name="r"><link name="&x;"/></robot>'
)
EXTERNAL_DTD = '<?xml version="1.0"?>\n<!DOCTYPE r SYSTEM "file:///etc/passwd">\n<robot name="r"/>'


@pytest.mark.parametrize("text", [LAUGHS, EXTERNAL], ids=["billion-laughs", "external-entity"])
@pytest.mark.parametrize("encoding", ["utf-8", "utf-16"])
def test_entities_are_refused(text: str, encoding: str) -> None:
    data = text.replace('version="1.0"?>', f'version="1.0" encoding="{encoding}"?>').encode(
        encoding
    )
    with pytest.raises(XMLError) as info:
        parse_xml(data, "evil.urdf")
    assert str(info.value).startswith("evil.urdf")
    assert "\n" not in str(info.value)


def test_external_dtd_is_never_loaded(tmp_path: Path) -> None:
    root = parse_xml(EXTERNAL_DTD.encode(), "dtd.urdf")
    assert root.tag == "robot"
    assert root.get("name") == "r"


def test_urdf_and_sdf_files_with_entities_are_refused(tmp_path: Path) -> None:
    urdf = tmp_path / "evil.urdf"
    urdf.write_text(LAUGHS)
    with pytest.raises(XMLError, match=r"evil\.urdf: entity declarations are not allowed"):
        load_robot(urdf)
    sdf = tmp_path / "evil.sdf"
    sdf.write_text(EXTERNAL.replace("<robot", "<sdf").replace("</robot>", "</sdf>"))
    with pytest.raises(ModelError, match=r"evil\.sdf: entity declarations are not allowed"):
        read_sdf(sdf)


def test_collada_mesh_with_entities_is_refused(tmp_path: Path) -> None:
    dae = tmp_path / "evil.dae"
    dae.write_text(LAUGHS.replace("<robot", "<COLLADA").replace('name="&lol9;"/>', "/>"))
    with pytest.raises(ModelError, match=r"evil\.dae: entity declarations are not allowed"):
        prepare_mesh(dae, cache_dir=tmp_path / "cache")


@pytest.mark.parametrize("suffix", [".urdf", ".sdf", ".xml", ".dae"])
def test_oversized_model_files_are_refused_before_reading(tmp_path: Path, suffix: str) -> None:
    big = tmp_path / f"huge{suffix}"
    with big.open("wb") as f:  # sparse: no disk space used
        f.truncate(MAX_XML_BYTES + 1)
    if suffix == ".dae":
        load = lambda: prepare_mesh(big, cache_dir=tmp_path / "cache")  # noqa: E731
    elif suffix == ".sdf":
        load = lambda: read_sdf(big)  # noqa: E731
    else:
        load = lambda: load_robot(big)  # noqa: E731
    with pytest.raises(ModelError) as info:
        load()
    text = str(info.value)
    assert f"huge{suffix}" in text
    assert "MiB limit" in text
    assert "\n" not in text
