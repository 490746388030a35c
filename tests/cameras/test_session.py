"""A session whose camera renders loads the SDF world with its visuals, materials, textures and
lights: the recorded image shows the red wall, the recording rebuilds to the same model from
its attachments (a texture beside the world too), and replays at --level full (issue 33)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from harness.recording import Recording
from harness.replay.source import rebuild_run
from harness.session import Session
from tests.cameras.scenes import CAMERA, POINT_LIGHT, RED, H, W, png, robot, world

TEXTURED = "<material><pbr><metal><albedo_map>red.png</albedo_map></metal></pbr></material>"


@pytest.mark.slow
@pytest.mark.parametrize("material", [RED, TEXTURED], ids=["material", "texture"])
def test_a_camera_session_records_the_world_as_gazebo_draws_it(
    tmp_path: Path, material: str
) -> None:
    (tmp_path / "w").mkdir()
    png(tmp_path / "w" / "red.png", (230, 20, 20))  # beside the world: attached as scene/red.png
    scene = world(tmp_path / "w", material, extra=POINT_LIGHT)
    path = tmp_path / "run.mcap"
    with Session(robot(tmp_path / "bot"), scene=scene, sensors=[CAMERA], record_to=path) as s:
        s.step(10)
        model = s.sim.model
        assert model.nlight == 1
    with Recording(path) as rec:
        msg = next(iter(rec.messages(["/cam/image_raw"])))
        image = rec.decode(msg)
        rgb = np.frombuffer(bytes(image.data), np.uint8).reshape(H, W, 3).astype(float)
        r, g, b = rgb[H // 2, W // 2]
        assert r > 3 * max(g, b), (r, g, b)
        rebuilt = rebuild_run(rec)  # from the carried sources, as replay rebuilds it
        assert rebuilt.sha256 == rec.metadata["model_sha256"]
        assert rebuilt.model.nlight == 1
    done = subprocess.run(
        [sys.executable, "-m", "harness", "replay", "--level", "full", str(path)],
        capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
