"""A depth camera in an SDF world measures the wall's visual as an independent ray cast of its
triangles (trimesh, not MuJoCo) does: Gazebo's depth cameras draw visuals, not collisions
(issue 33)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import trimesh

from tests.cameras.scenes import EYE, HFOV, RED, WALL_X, H, W, robot, view, world


def test_depth_image_matches_a_ray_cast_of_the_wall(tmp_path: Path) -> None:
    # the visual turned 20 degrees about z and moved 0.3 m to the side of its collision box
    # (depth then varies per column; main drew the straight collision box instead)
    wall = world(tmp_path / "w", RED, wall_x=WALL_X)
    turned = '<visual name="visual"><pose>0 0.3 0 0 0 0.35</pose>'
    wall.write_text(wall.read_text().replace('<visual name="visual">', turned))
    _, depth, model = view(robot(tmp_path / "bot"), wall)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    eye = data.xpos[model.body("base_link").id] + np.array([0.0, 0.0, EYE])

    box = trimesh.creation.box(extents=(0.1, 8.0, 2.0))
    box.apply_transform(trimesh.transformations.rotation_matrix(0.35, (0, 0, 1)))
    box.apply_translation((WALL_X, 0.3, 1.0))
    fx = (W / 2) / np.tan(HFOV / 2)
    u, v = np.meshgrid(np.arange(W) - (W - 1) / 2, np.arange(H) - (H - 1) / 2)
    # optical frame (x right, y down, z forward) in the world: forward +x, right -y, down -z
    rays = np.stack([np.ones_like(u), -u / fx, -v / fx], axis=-1).reshape(-1, 3)
    origins = np.repeat(eye[None, :], len(rays), axis=0)
    hits, index, _ = box.ray.intersects_location(origins, rays, multiple_hits=False)
    expected = np.full(H * W, np.inf)
    expected[index] = (hits - eye)[:, 0]  # depth: the distance along the optical axis (+x)
    expected = expected.reshape(H, W)

    hit = np.isfinite(expected) & np.isfinite(depth)
    edge = np.isfinite(expected) != np.isfinite(depth)
    assert hit.sum() > 0.5 * H * W
    assert edge.sum() <= 2 * W  # at most the wall's bottom edge row(s) differ
    error = np.abs(depth[hit] - expected[hit])
    assert error.max() < 5e-3  # the depth buffer's resolution at 2 m (near 0.05 m, far 20 m)
    assert np.median(error) < 2e-3
    assert np.ptp(expected[hit]) > 0.3  # a turned wall: not one distance
