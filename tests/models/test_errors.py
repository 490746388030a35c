"""Every bad input is one ModelError line naming the file and the element; XML is parsed safely."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from harness.errors import HarnessError
from harness.models import load_description, load_robot
from harness.models.errors import (
    MasslessLinkError,
    MeshError,
    ModelStructureError,
    ModelWarning,
    ResolveError,
    UnknownPackageError,
    XMLError,
)

INERTIA = '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
LINK = '<link name="{name}"><inertial><mass value="1"/>' + INERTIA + "</inertial>{extra}</link>"


def _urdf(tmp_path: Path, body: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<robot name="r">\n{body}\n</robot>\n')
    return path


def _chain(joint_type: str = "revolute", child_extra: str = "", child_inertial: bool = True) -> str:
    child = LINK.format(name="b", extra=child_extra) if child_inertial else '<link name="b"/>'
    return "\n".join(
        [
            LINK.format(name="a", extra=""),
            child,
            f'<joint name="j" type="{joint_type}"><parent link="a"/><child link="b"/>'
            '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
        ]
    )


def test_malformed_xml_names_file_and_line(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="r">\n<link name="a">\n</robot>\n')
    with pytest.raises(XMLError, match=r"broken\.urdf:3: malformed XML: .*link"):
        load_robot(path)


def test_billion_laughs_is_rejected_at_once(tmp_path):
    levels = ['<!ENTITY lol0 "lol">'] + [
        f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">' for i in range(1, 10)
    ]
    path = tmp_path / "laughs.urdf"
    path.write_text(
        '<?xml version="1.0"?>\n<!DOCTYPE robot [\n' + "\n".join(levels) + "\n]>\n"
        '<robot name="&lol9;"><link name="a"/></robot>\n'
    )
    with pytest.raises(XMLError, match=r"laughs\.urdf: entity declarations are not allowed"):
        load_description(path)
    with pytest.raises(XMLError, match="entity declarations"):
        load_robot(path)


def test_external_entities_are_never_fetched(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("SECRET")
    path = tmp_path / "xxe.urdf"
    path.write_text(
        f'<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY x SYSTEM "file://{secret}">]>\n'
        '<robot name="&x;"><link name="a"/></robot>\n'
    )
    with pytest.raises(XMLError, match="entity declarations"):
        load_description(path)


def test_missing_mesh_names_link_and_path(tmp_path):
    path = _urdf(
        tmp_path,
        _chain(
            child_extra='<collision><geometry><mesh filename="meshes/gone.stl"/></geometry>'
            "</collision>"
        ),
    )
    with pytest.raises(
        ResolveError,
        match=r"robot\.urdf: line \d+: <link name=\"b\">: mesh not found: .*gone\.stl"
        r".*from 'meshes/gone\.stl'",
    ):
        load_robot(path)


def test_unknown_package_says_what_was_tried(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros_ws"))
    path = _urdf(
        tmp_path,
        _chain(
            child_extra='<collision><geometry><mesh filename="package://nowhere_pkg/m.stl"/></geometry></collision>'
        ),
    )
    with pytest.raises(UnknownPackageError) as info:
        load_robot(path, packages={"other": tmp_path})
    message = str(info.value)
    assert "robot.urdf" in message
    assert '<link name="b">' in message
    assert "unknown package 'nowhere_pkg'" in message
    assert "packages map ['other']" in message
    assert str(tmp_path / "ros_ws") in message
    assert f"the folders above {tmp_path.resolve()}" in message


def test_massless_moving_link_is_named_and_repairable(tmp_path):
    path = _urdf(tmp_path, _chain(child_inertial=False))
    with pytest.raises(
        MasslessLinkError,
        match=r"robot\.urdf: <link name=\"b\">: moving link has no mass.*repair_inertia=True",
    ):
        load_robot(path, strict=True)
    with pytest.warns(ModelWarning, match=r"robot\.urdf: repaired .* b: mass 0 -> 0\.0001 kg"):
        repaired = load_robot(path)  # the default repairs, and says so
    assert repaired.repairs == (
        "b: mass 0 -> 0.0001 kg (boundmass)",
        "b: principal inertia raised to 1e-08 kg m^2 (boundinertia)",
    )
    assert repaired.model.body_mass[repaired.model.body("b").id] == pytest.approx(1e-4)


def test_repairs_name_exactly_the_changed_links(tmp_path):
    bad_inertia = (
        '<link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.05"/></inertial></link>'
    )
    body = "\n".join(
        [
            LINK.format(name="a", extra=""),
            bad_inertia,
            '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
        ]
    )
    path = _urdf(tmp_path, body)
    with pytest.raises(HarnessError, match=r"<link name=\"b\">: inertia violates the triangle"):
        load_robot(path, strict=True)
    repaired = load_robot(path, repair_inertia=True)
    assert len(repaired.repairs) == 1
    assert repaired.repairs[0].startswith("b: inertia [0.01, 0.01, 0.05] -> ")
    assert repaired.repairs[0].endswith("(balanceinertia)")
    assert load_robot("demo", repair_inertia=True).repairs == ()


def test_unsupported_mesh_format(tmp_path):
    (tmp_path / "part.3ds").write_bytes(b"\x00" * 16)
    path = _urdf(
        tmp_path,
        _chain(
            child_extra='<collision><geometry><mesh filename="part.3ds"/></geometry></collision>'
        ),
    )
    with pytest.raises(MeshError, match=r"<link name=\"b\">: unsupported mesh format '\.3ds'"):
        load_robot(path)


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        (
            LINK.format(name="a", extra="")
            + '<joint name="j" type="fixed"><parent link="a"/><child link="ghost"/></joint>',
            r'<joint name="j">: child link \'ghost\' does not exist',
        ),
        (
            LINK.format(name="a", extra="")
            + '<joint name="j" type="fixed"><parent link="nobody"/><child link="a"/></joint>',
            r'<joint name="j">: parent link \'nobody\' does not exist',
        ),
        (
            LINK.format(name="a", extra="")
            + '<joint name="j" type="fixed"><parent link="a"/></joint>',
            r'<joint name="j">: missing <child link=\.\.\.>',
        ),
        (_chain(joint_type="spherical"), r'<joint name="j">: unknown joint type \'spherical\''),
    ],
)
def test_structure_errors_name_the_element(tmp_path, body, pattern):
    path = _urdf(tmp_path, body)
    with pytest.raises(ModelStructureError, match=r"robot\.urdf: line \d+: " + pattern):
        load_description(path)


def test_cli_turns_model_errors_into_one_line_and_exit_code_2(tmp_path):
    path = _urdf(tmp_path, _chain(joint_type="spherical"))
    result = subprocess.run(
        [sys.executable, "-m", "harness", "inspect-model", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert lines[0].startswith("harness inspect-model: error: ")
    assert "unknown joint type 'spherical'" in lines[0]


def test_sdf_and_unknown_formats(tmp_path):
    path = tmp_path / "robot.obj"
    path.write_text("v 0 0 0\n")
    with pytest.raises(ModelStructureError, match=r"robot\.obj: unknown model format '\.obj'"):
        load_robot(path)
    with pytest.raises(ModelStructureError, match=r"model file not found"):
        load_robot(tmp_path / "missing.urdf")
