"""Every source file attached once, by content; visual-only meshes only when visuals were
asked (issue 35, "Small goldens")."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from harness import Session
from harness.models import load_robot
from harness.recording import Recording
from harness.replay import verify
from harness.replay.source import rebuild_robot

DATA = Path(__file__).resolve().parents[1] / "data"
INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)


def _package(root: Path) -> tuple[Path, bytes, bytes]:
    """A ROS package ``pkg`` whose URDF references one collision mesh twice (through
    ``package://`` and by a relative path) and has a visual-only mesh: (URDF, collision
    mesh bytes, visual mesh bytes)."""
    meshes = sorted(p for p in DATA.rglob("*.stl") if p.stat().st_size < 20_000)
    part, look = meshes[0].read_bytes(), meshes[1].read_bytes()
    assert part != look
    package = root / "pkg"
    (package / "meshes").mkdir(parents=True)
    (package / "urdf").mkdir()
    (package / "package.xml").write_text("<package><name>pkg</name></package>")
    (package / "meshes" / "part.stl").write_bytes(part)
    (package / "meshes" / "look.stl").write_bytes(look)
    scale = 'scale="0.001 0.001 0.001"'
    link = (
        '<link name="{name}">' + INERTIAL + "<collision><geometry>"
        '<mesh filename="{uri}" ' + scale + "/></geometry></collision>"
        '<visual><geometry><mesh filename="package://pkg/meshes/look.stl" ' + scale + "/>"
        "</geometry></visual></link>"
    )
    joint = (
        '<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        '<origin xyz="0 0 0.2"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
    )
    urdf = package / "urdf" / "arm.urdf"
    urdf.write_text(
        '<?xml version="1.0"?><robot name="arm"><link name="base">'
        + INERTIAL
        + "</link>"
        + link.format(name="a", uri="package://pkg/meshes/part.stl")
        + link.format(name="b", uri="../meshes/part.stl")
        + joint.format(i=1, parent="base", child="a")
        + joint.format(i=2, parent="a", child="b")
        + "</robot>"
    )
    return urdf, part, look


def _holding(rec: Recording, blob: bytes) -> list[str]:
    return [name for name, data in rec.attachments.items() if data == blob]


@pytest.mark.parametrize("visuals", [False, True], ids=["collision-only", "visuals"])
def test_a_twice_referenced_mesh_is_attached_once_and_rebuilds(
    tmp_path: Path, visuals: bool
) -> None:
    urdf, part, look = _package(tmp_path / "src")
    path = tmp_path / "run.mcap"
    with Session(load_robot(urdf, visuals=visuals), record_to=path) as session:
        session.set_positions({"j1": 0.3})
        session.step(20)
    shutil.rmtree(tmp_path / "src")  # the rebuild reads the recording only
    with Recording(path) as rec:
        assert len(_holding(rec, part)) == 1, rec.attachment_names
        links = json.loads(rec.attachment("source-links.json"))
        # the other spelling of the same mesh, laid out from the one attachment
        assert sorted({*links, *links.values()}) == ["meshes/part.stl", "pkg/meshes/part.stl"]
        if visuals:
            assert len(_holding(rec, look)) == 1
            assert rec.metadata["visuals"] == "true"
        else:
            assert _holding(rec, look) == []  # the model has no visual geom to rebuild
            assert "visuals" not in rec.metadata
        rebuilt = rebuild_robot(rec)
        assert rebuilt.sha256 == rec.metadata["model_sha256"]
        assert rebuilt.model.nmesh == (2 if visuals else 1)
    report = verify(path, level="full")
    assert report.reproduced, report


def test_two_robots_of_one_urdf_carry_it_once(tmp_path: Path) -> None:
    from harness.models import RobotSpec

    path = tmp_path / "two.mcap"
    robots = [
        RobotSpec("demo", namespace="left"),
        RobotSpec("demo", namespace="right", pose=(0.0, 1.0, 0.0)),
    ]
    with Session(robots=robots, record_to=path) as session:
        session.step(5)
    with Recording(path) as rec:
        urdfs = [n for n in rec.attachment_names if n.startswith("source/model/")]
        assert len(urdfs) == 1, rec.attachment_names
        assert json.loads(rec.attachment("source-links.json")) == {
            "model/right/demo_arm.urdf": "model/left/demo_arm.urdf"
        }
    assert verify(path, level="full").reproduced
