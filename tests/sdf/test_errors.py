"""Bad SDF gets one clear error naming the file and the element."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.errors import ModelError
from harness.models.sdf import (
    SdfCycleError,
    SdfFrameError,
    SdfIncludeError,
    SdfInertiaError,
    SdfStructureError,
    SdfSyntaxError,
    SdfVersionError,
    read_sdf,
)


def _write(tmp_path: Path, body: str, version: str = "1.8", name: str = "m.sdf") -> Path:
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<sdf version="{version}">\n{body}\n</sdf>\n')
    return path


def _model(inner: str) -> str:
    return f'<model name="m">\n<link name="L"/>\n{inner}\n</model>'


def test_unknown_frame_reference(tmp_path: Path) -> None:
    path = _write(
        tmp_path, _model('<frame name="F"><pose relative_to="nope">0 0 0 0 0 0</pose></frame>')
    )
    with pytest.raises(SdfFrameError) as info:
        read_sdf(path)
    message = str(info.value)
    assert str(path) in message
    assert '<frame name="F">' in message
    assert "unknown frame 'nope' in relative_to" in message


def test_unknown_nested_reference(tmp_path: Path) -> None:
    inner = '<model name="M"><link name="A"/></model><frame name="F" attached_to="M::B"/>'
    with pytest.raises(SdfFrameError, match=r"unknown frame 'M::B' in attached_to.*model 'M'"):
        read_sdf(_write(tmp_path, _model(inner)))


def test_unknown_joint_child(tmp_path: Path) -> None:
    inner = '<joint name="J" type="fixed"><parent>L</parent><child>ghost</child></joint>'
    with pytest.raises(SdfFrameError, match=r'<joint name="J">: unknown frame \'ghost\' in child'):
        read_sdf(_write(tmp_path, _model(inner)))


def test_cycle_in_attached_to(tmp_path: Path) -> None:
    inner = (
        '<frame name="A" attached_to="B"><pose relative_to="__model__"/></frame>\n'
        '<frame name="B" attached_to="A"><pose relative_to="__model__"/></frame>'
    )
    with pytest.raises(SdfCycleError, match=r"cycle in attached_to: A -> B -> A"):
        read_sdf(_write(tmp_path, _model(inner)))


def test_cycle_in_relative_to(tmp_path: Path) -> None:
    inner = (
        '<frame name="A"><pose relative_to="B">1 0 0 0 0 0</pose></frame>\n'
        '<frame name="B"><pose relative_to="A">1 0 0 0 0 0</pose></frame>'
    )
    with pytest.raises(SdfCycleError, match=r'<frame name="A">: cycle in relative_to: A -> B -> A'):
        read_sdf(_write(tmp_path, _model(inner)))


def test_self_reference_is_a_cycle(tmp_path: Path) -> None:
    inner = '<link name="K"><pose relative_to="K"/></link>'
    with pytest.raises(SdfCycleError, match="K is relative to itself"):
        read_sdf(_write(tmp_path, _model(inner)))


def test_missing_include(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for var in (
        "GZ_SIM_RESOURCE_PATH",
        "SDF_PATH",
        "IGN_GAZEBO_RESOURCE_PATH",
        "GAZEBO_MODEL_PATH",
    ):
        monkeypatch.delenv(var, raising=False)
    path = _write(tmp_path, '<world name="w"><include><uri>model://nowhere</uri></include></world>')
    with pytest.raises(SdfIncludeError) as info:
        read_sdf(path)
    message = str(info.value)
    assert str(path) in message
    assert "<include>" in message
    assert "missing include 'model://nowhere'" in message


def test_missing_relative_include(tmp_path: Path) -> None:
    path = _write(tmp_path, '<world name="w"><include><uri>models/gone</uri></include></world>')
    with pytest.raises(SdfIncludeError, match=r"missing include 'models/gone': .*does not exist"):
        read_sdf(path)


def test_include_found_through_search_variable(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "lib" / "widget"
    folder.mkdir(parents=True)
    (folder / "model.config").write_text(
        '<model><name>w</name><sdf version="1.6">w.sdf</sdf><sdf version="1.9">w9.sdf</sdf></model>'
    )
    _write(folder, '<model name="widget"><link name="base"/></model>', "1.9", "w9.sdf")
    monkeypatch.setenv("SDF_PATH", str(tmp_path / "lib"))
    world = _write(
        tmp_path,
        '<world name="w"><include><uri>model://widget</uri><name>w2</name>'
        "<pose>1 2 3 0 0 0</pose><static>true</static></include></world>",
        name="world.sdf",
    )
    model = read_sdf(world)
    assert model.name == "w2"
    assert [link.name for link in model.links] == ["base"]
    assert not model.joints  # static: welded to the world, no free joint


def test_include_cycle(tmp_path: Path) -> None:
    _write(
        tmp_path,
        '<model name="a"><link name="L"/><include><uri>b.sdf</uri></include></model>',
        name="a.sdf",
    )
    _write(
        tmp_path,
        '<model name="b"><link name="L"/><include><uri>a.sdf</uri></include></model>',
        name="b.sdf",
    )
    with pytest.raises(SdfCycleError, match=r"include cycle: .*a.sdf -> .*b.sdf -> .*a.sdf"):
        read_sdf(tmp_path / "a.sdf")


@pytest.mark.parametrize("version", ["1.3", "2.0", "1.12", "one"])
def test_unsupported_version(tmp_path: Path, version: str) -> None:
    path = _write(tmp_path, _model(""), version)
    with pytest.raises(SdfVersionError) as info:
        read_sdf(path)
    assert f"unsupported SDFormat version '{version}' (supported: 1.4-1.11)" in str(info.value)
    assert str(path) in str(info.value)


def test_missing_version(tmp_path: Path) -> None:
    path = tmp_path / "m.sdf"
    path.write_text(f"<sdf>{_model('')}</sdf>")
    with pytest.raises(SdfVersionError, match="unsupported SDFormat no version attribute"):
        read_sdf(path)


@pytest.mark.parametrize(
    ("inertial", "reason"),
    [
        ("<mass>-1</mass>", "mass -1.0 must be positive"),
        (
            "<mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>3</izz></inertia>",
            "violate the triangle inequality",
        ),
        (
            "<mass>1</mass><inertia><ixx>-1</ixx><iyy>1</iyy><izz>1</izz></inertia>",
            "must be positive",
        ),
    ],
)
def test_invalid_inertia(tmp_path: Path, inertial: str, reason: str) -> None:
    path = _write(
        tmp_path,
        f'<model name="m"><link name="heavy"><inertial>{inertial}</inertial></link></model>',
    )
    with pytest.raises(SdfInertiaError) as info:
        read_sdf(path)
    assert "<inertial>" in str(info.value)
    assert "invalid inertia" in str(info.value)
    assert reason in str(info.value)


@pytest.mark.parametrize(
    ("pose", "reason"),
    [
        ("<pose>1 2 x 0 0 0</pose>", "is not a list of numbers"),
        ("<pose>1 2 3</pose>", "needs 6 numbers, not 3"),
        ('<pose rotation_format="quat_xyzw">1 2 3 0 0 0</pose>', "needs 7 numbers, not 6"),
        ('<pose rotation_format="quat_xyzw" degrees="true">0 0 0 0 0 0 1</pose>', "degrees"),
        ('<pose rotation_format="axis_angle">0 0 0 0 0 1</pose>', "unknown rotation_format"),
        ('<pose degrees="maybe">0 0 0 0 0 0</pose>', "is not a boolean"),
    ],
)
def test_malformed_pose(tmp_path: Path, pose: str, reason: str) -> None:
    path = _write(tmp_path, _model(f'<frame name="F">{pose}</frame>'), "1.9")
    with pytest.raises(SdfSyntaxError, match=reason) as info:
        read_sdf(path)
    assert "<pose>" in str(info.value)


def test_duplicate_names(tmp_path: Path) -> None:
    with pytest.raises(SdfStructureError, match=r"name 'L' is already used by link"):
        read_sdf(_write(tmp_path, _model('<frame name="L"/>')))


def test_model_not_in_world(tmp_path: Path) -> None:
    path = _write(tmp_path, '<world name="w"><model name="a"><link name="L"/></model></world>')
    with pytest.raises(SdfStructureError, match=r"no model named 'b' \(models: \['a'\]\)"):
        read_sdf(path, model="b")


def test_unsafe_xml_is_a_model_error(tmp_path: Path) -> None:
    path = tmp_path / "m.sdf"
    path.write_text('<!DOCTYPE sdf [<!ENTITY x "y">]><sdf version="1.8"><model name="&x;"/></sdf>')
    with pytest.raises(ModelError, match="entity declarations are not allowed"):
        read_sdf(path)
