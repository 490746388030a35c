"""An MJCF or SDF robot publishes a URDF on /robot_description: yourdfpy (the test oracle)
reads it, and its forward kinematics at the zero configuration puts every link where the
robot's description does."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

from harness.models import load_robot
from harness.session import Session
from harness.session.core.urdf_text import urdf_of

DATA = Path(__file__).resolve().parents[1] / "data"


def _check_fk(text: str, robot_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        description = load_robot(robot_path).description
    urdf = yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=True, load_meshes=False)
    assert set(urdf.link_map) >= {link.name for link in description.links}
    root = urdf.base_link
    for link in description.links:
        expected = link.pose.matrix()
        actual = urdf.get_transform(frame_to=link.name, frame_from=root)
        np.testing.assert_allclose(actual, expected, atol=1e-9, err_msg=link.name)
    movable = {j.name for j in description.joints if j.type in ("revolute", "prismatic")}
    assert movable <= set(urdf.joint_map)


@pytest.mark.parametrize(
    "robot",
    ["recording/arm.xml", "sdf/joint_axis_frame_1_5_rotated_child.sdf"],
)
def test_written_urdf_matches_the_description(robot: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loaded = load_robot(DATA / robot)
    text = urdf_of(loaded.description)
    assert text is not None
    _check_fk(text, DATA / robot)


def test_an_mjcf_session_publishes_urdf(tmp_path: Path) -> None:
    from harness.recording import Recording

    path = tmp_path / "mjcf.mcap"
    with Session(DATA / "recording" / "arm.xml", record_to=path) as session:
        session.step(1)
    with Recording(path) as rec:
        (message,) = list(rec.messages("/robot_description", decode=True))
    text = message.msg.data
    assert text.lstrip().startswith("<?xml")
    assert "<robot " in text
    _check_fk(text, DATA / "recording" / "arm.xml")
