"""Cameras see world and robot visuals in their materials' colours, as Gazebo draws them
(issue 33, "Cameras see what Gazebo's cameras see")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from harness.models.sdf.errors import SdfWarning
from tests.cameras.scenes import GAZEBO_BLUE, RED, H, W, robot, view, world


def _centre(rgb: np.ndarray) -> np.ndarray:
    return rgb[H // 2 - 2 : H // 2 + 2, W // 2 - 2 : W // 2 + 2].reshape(-1, 3).mean(axis=0)


def test_a_wall_with_an_sdf_material_is_seen_red(tmp_path: Path) -> None:
    rgb, _, model = view(robot(tmp_path / "bot"), world(tmp_path / "w", RED))
    r, g, b = _centre(rgb)
    # No light in the world: gz lights it by the scene's ambient (0.4) alone; the diffuse
    # 0.9 red gives 0.4 * 0.9 * 255 = 92 (main: uniform dark grey 13, 13, 13).
    assert r > 3 * max(g, b), (r, g, b)
    assert r == pytest.approx(0.4 * 0.9 * 255, abs=6)
    assert model.nlight == 0


def test_a_wall_with_gazebo_blue_is_seen_blue(tmp_path: Path) -> None:
    rgb, _, _ = view(robot(tmp_path / "bot"), world(tmp_path / "w", GAZEBO_BLUE))
    r, g, b = _centre(rgb)
    assert b > 3 * max(r, g), (r, g, b)


def test_a_gazebo_classic_named_grey_wall_is_grey_not_default(tmp_path: Path) -> None:
    named = "<material><script><name>Gazebo/DarkGrey</name></script></material>"
    dark, _, _ = view(robot(tmp_path / "bot"), world(tmp_path / "a", named))
    plain, _, _ = view(robot(tmp_path / "bot"), world(tmp_path / "b", ""))
    # Gazebo/DarkGrey is diffuse 0.175; a primitive without a material is gz's 0.7 grey
    assert _centre(dark) == pytest.approx([0.4 * 0.175 * 255] * 3, abs=4)
    assert _centre(plain) == pytest.approx([0.4 * 0.7 * 255] * 3, abs=4)


def test_urdf_named_material_and_gazebo_reference_colour_the_robot(tmp_path: Path) -> None:
    markers = [
        ("named", 0.3, 0.5, '<material name="marker_orange"/>'),
        ("gz", -0.3, 0.5, ""),
    ]
    gazebo = '  <gazebo reference="gz"><material>Gazebo/Green</material></gazebo>\n'
    rgb, _, _ = view(robot(tmp_path / "bot", markers, gazebo), world(tmp_path / "w", RED))
    # the markers are 1 m ahead, 0.3 m to the left and right: 0.3 / 1 * fx pixels off centre
    fx = (W / 2) / np.tan(0.5)
    left = rgb[H // 2, round((W - 1) / 2 - 0.3 * fx)].astype(float)
    right = rgb[H // 2, round((W - 1) / 2 + 0.3 * fx)].astype(float)
    # the robot-level <material name="marker_orange"> (1, 0.45, 0) referenced by name
    assert left[0] > left[1] > 3 * left[2], left
    assert left[1] / left[0] == pytest.approx(0.45, abs=0.06)
    # <gazebo reference="gz"><material>Gazebo/Green</material>: Gazebo draws it green
    assert right[1] > 3 * max(right[0], right[2]), right


def test_a_malformed_colour_is_one_warning_and_the_world_loads(tmp_path: Path) -> None:
    bad = "<material><diffuse>red</diffuse></material>"
    with pytest.warns(SdfWarning, match=r"colour 'red' needs 3 or 4 numbers \(drawn grey\)"):
        rgb, _, _ = view(robot(tmp_path / "bot"), world(tmp_path / "w", bad))
    r, g, b = _centre(rgb)
    assert r == g == b
