"""A visual's ``<pbr><metal><albedo_map>`` PNG is drawn as a MuJoCo texture, and a COLLADA
mesh visual without an SDF material is drawn in the mesh's own colour (issue 33)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from harness.models.sdf.errors import SdfWarning
from tests.cameras.collada import collada
from tests.cameras.scenes import GAZEBO_BLUE, H, W, png, robot, view, world


def _centre(rgb: np.ndarray) -> np.ndarray:
    return rgb[H // 2 - 2 : H // 2 + 2, W // 2 - 2 : W // 2 + 2].reshape(-1, 3).mean(axis=0)


def test_an_albedo_map_texture_is_drawn(tmp_path: Path) -> None:
    folder = tmp_path / "w"
    folder.mkdir()
    png(folder / "green.png", (20, 230, 40))
    material = "<material><pbr><metal><albedo_map>green.png</albedo_map></metal></pbr></material>"
    rgb, _, model = view(robot(tmp_path / "bot"), world(folder, material))
    assert model.ntex == 1
    r, g, b = _centre(rgb)
    assert g > 3 * max(r, b), (r, g, b)


def test_a_missing_texture_is_one_warning_and_the_colour_is_drawn(tmp_path: Path) -> None:
    material = GAZEBO_BLUE.replace(
        "</material>", "<pbr><metal><albedo_map>gone.png</albedo_map></metal></pbr></material>"
    )
    with pytest.warns(SdfWarning, match="gone.png"):
        rgb, _, model = view(robot(tmp_path / "bot"), world(tmp_path / "w", material))
    assert model.ntex == 0
    r, g, b = _centre(rgb)
    assert b > 3 * max(r, g), (r, g, b)


def test_a_collada_mesh_without_material_is_drawn_in_its_own_colour(tmp_path: Path) -> None:
    folder = tmp_path / "w"
    folder.mkdir()
    collada(folder / "quad.dae", color="0.1 0.2 0.9 1")  # a 2 m square, blue in its effect
    path = world(folder, "")
    text = path.read_text()
    head, _, tail = text.partition('<visual name="visual"><geometry>')
    tail = tail.split("</geometry>", 1)[1]
    mesh = "<mesh><uri>quad.dae</uri></mesh>"
    path.write_text(f'{head}<visual name="visual"><geometry>{mesh}</geometry>{tail}')
    rgb, _, _ = view(robot(tmp_path / "bot"), path)
    r, g, b = _centre(rgb)
    assert b > 3 * max(r, g), (r, g, b)  # main: MuJoCo's grey
    assert b == pytest.approx(0.4 * 0.9 * 255, abs=6)


def test_a_visual_mesh_not_at_hand_is_one_warning_and_not_drawn(tmp_path: Path) -> None:
    path = world(tmp_path / "w", "")
    text = path.read_text()
    head, _, tail = text.partition('<visual name="visual"><geometry>')
    tail = tail.split("</geometry>", 1)[1]
    mesh = "<mesh><uri>model://not_here/meshes/wall.stl</uri></mesh>"
    path.write_text(f'{head}<visual name="visual"><geometry>{mesh}</geometry>{tail}')
    with pytest.warns(SdfWarning, match=r"1 visual mesh\(es\) not found, left out .*not_here"):
        rgb, _, model = view(robot(tmp_path / "bot"), path)
    assert model.ngeom > 0
    # Gazebo draws nothing there: the scene's background (SDF's default 0.7 grey)
    assert rgb[H // 2, W // 2].tolist() == [178, 178, 178]
