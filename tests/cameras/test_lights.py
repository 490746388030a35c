"""Cameras see a world lit by its ``<light>``s and its ``<scene><ambient>``, as gz-sim lights
it (issue 33): no light at all is the ambient light alone; a point light brightens the wall
near it; a sun (a light-only include) lights a face turned to it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cameras.scenes import POINT_LIGHT, RED, H, W, robot, view, world

GREY = "<material><diffuse>0.5 0.5 0.5 1</diffuse></material>"


def _third(rgb: np.ndarray, which: int) -> float:
    """The mean brightness of the left (0), middle (1) or right (2) third of the image."""
    part = rgb[H // 4 : 3 * H // 4, which * W // 3 : (which + 1) * W // 3]
    return float(part.mean())


def test_a_point_light_brightens_the_wall_near_it(tmp_path: Path) -> None:
    bot = robot(tmp_path / "bot")
    dark, _, _ = view(bot, world(tmp_path / "a", GREY))
    lit, _, model = view(bot, world(tmp_path / "b", GREY, extra=POINT_LIGHT))
    assert model.nlight == 1
    # without light: the ambient light alone, the same everywhere on the wall
    assert _third(dark, 0) == pytest.approx(_third(dark, 2), abs=2)
    assert _third(dark, 1) == pytest.approx(0.4 * 0.5 * 255, abs=4)
    # the bulb is 0.35 m in front of the wall, on its left (+y is left in the image)
    assert _third(lit, 0) > _third(lit, 2) + 30
    assert _third(lit, 0) > _third(dark, 0) + 40
    # the far (right) part gets much less light than the near (left) one
    assert _third(lit, 2) - _third(dark, 2) < 0.5 * (_third(lit, 0) - _third(dark, 0))


def test_the_scene_ambient_light_is_the_worlds(tmp_path: Path) -> None:
    scene = "    <scene><ambient>0.1 0.1 0.1 1</ambient></scene>\n"
    rgb, _, model = view(robot(tmp_path / "bot"), world(tmp_path / "w", RED, extra=scene))
    centre = rgb[H // 2, W // 2].astype(float)
    assert centre[0] == pytest.approx(0.1 * 0.9 * 255, abs=4)
    assert list(model.vis.headlight.ambient) == pytest.approx([0.1, 0.1, 0.1])
    assert list(model.vis.headlight.diffuse) == [0.0, 0.0, 0.0]


def test_an_included_sun_lights_the_face_turned_to_it(tmp_path: Path) -> None:
    folder = tmp_path / "w"
    sun = folder / "my_sun"
    sun.mkdir(parents=True)
    (sun / "model.sdf").write_text(
        '<?xml version="1.0"?><sdf version="1.6"><light type="directional" name="sun">'
        "<diffuse>0.5 0.5 0.5 1</diffuse><specular>0 0 0 1</specular>"
        "<direction>1 0 -1</direction></light></sdf>"
    )
    include = "    <include><uri>model://my_sun</uri></include>\n"
    bot = robot(tmp_path / "bot")
    rgb, _, model = view(bot, world(folder, GREY, extra=include))
    assert model.nlight == 1
    assert model.light_type[0] == 1  # directional
    # ambient 0.4 plus the sun's 0.5 at 45 degrees to the face, on a 0.5 grey
    expected = (0.4 + 0.5 * np.sqrt(0.5)) * 0.5 * 255
    assert float(rgb[H // 2, W // 2].mean()) == pytest.approx(expected, abs=6)


def test_the_scene_background_fills_what_nothing_covers(tmp_path: Path) -> None:
    scene = "    <scene><background>0.1 0.2 0.9 1</background></scene>\n"
    rgb, depth, _ = view(robot(tmp_path / "bot"), world(tmp_path / "w", RED, extra=scene))
    # the bottom rows look below the wall (there is no floor): nothing is drawn there
    assert np.isinf(depth[-1]).all()
    assert (rgb[-1] == [26, 51, 230]).all()  # main: MuJoCo's black
    assert np.isfinite(depth[H // 2, W // 2])
    assert rgb[H // 2, W // 2, 0] > 3 * rgb[H // 2, W // 2, 2]  # the red wall is not touched
