"""Cameras on the rig: a green 0.5 m cube whose near face is 1.75 m ahead of the mount."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

W, H, HFOV = 64, 48, 1.0
FACE = 1.75  # m from the mount to the cube's near face
HALF = 0.25  # m, half the cube's edge
CAMERA = {"name": "cam", "type": "rgbd", "parent": "mount", "width": W, "height": H, "hfov": HFOV}


def _rgb(msg: dict) -> np.ndarray:
    assert msg["encoding"] == "rgb8"
    assert msg["step"] == W * 3
    return np.frombuffer(msg["data"], np.uint8).reshape(H, W, 3)


def _depth(msg: dict) -> np.ndarray:
    assert msg["encoding"] == "32FC1"
    assert msg["step"] == W * 4
    return np.frombuffer(msg["data"], "<f4").reshape(H, W)


def test_camera_info_k_matches_the_field_of_view(rig) -> None:
    out = rig([CAMERA]).read()
    info = out["/cam/camera_info"]
    fx = (W / 2) / math.tan(HFOV / 2)
    k = info["k"]
    assert k[0] == pytest.approx(fx)
    assert k[4] == pytest.approx(fx)
    assert (k[2], k[5]) == ((W - 1) / 2, (H - 1) / 2)
    assert (info["width"], info["height"]) == (W, H)
    assert info["header"]["frame_id"] == "cam_optical"


def test_rgb_image_shows_the_cube_at_the_projected_pixels(rig) -> None:
    image = _rgb(rig([CAMERA]).read()["/cam/image_raw"])
    green = (image[..., 1] > 200) & (image[..., 0] < 60) & (image[..., 2] < 60)
    fx = (W / 2) / math.tan(HFOV / 2)
    half_px = HALF / FACE * fx  # the face's half width in pixels
    u = np.arange(W) - (W - 1) / 2
    v = np.arange(H) - (H - 1) / 2
    inside = (np.abs(u)[None, :] < half_px - 0.5) & (np.abs(v)[:, None] < half_px - 0.5)
    outside = (np.abs(u)[None, :] > half_px + 0.5) | (np.abs(v)[:, None] > half_px + 0.5)
    assert green[inside].all()
    assert not green[outside].any()
    assert image[0, 0].max() < 60  # background is dark, not green


def test_depth_is_the_face_distance_within_a_millimetre(rig) -> None:
    out = rig([CAMERA]).read()
    depth = _depth(out["/cam/depth/image_raw"])
    centre = depth[H // 2 - 3 : H // 2 + 3, W // 2 - 3 : W // 2 + 3]
    assert np.abs(centre - FACE).max() < 1e-3
    assert np.isinf(depth[0, 0])  # nothing there within the far clip
    cloud = out["/cam/points"]
    points = np.frombuffer(cloud["data"], "<f4").reshape(H, W, 3)
    assert cloud["point_step"] == 12
    assert not cloud["is_dense"]
    assert points[H // 2, W // 2, 2] == pytest.approx(FACE, abs=1e-3)
    assert np.isnan(points[0, 0]).all()


def test_compressed_image_is_the_same_pixels_as_png(rig) -> None:
    out = rig([CAMERA]).read()
    png = out["/cam/image_raw/compressed"]["data"]
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    body = png[png.index(b"IDAT") + 4 : png.index(b"IEND") - 8]
    rows = np.frombuffer(zlib.decompress(body), np.uint8).reshape(H, 1 + W * 3)
    assert (rows[:, 1:].reshape(H, W, 3) == _rgb(out["/cam/image_raw"])).all()


def test_mjcf_camera_by_name_takes_its_pose_and_fovy(rig) -> None:
    sensor = {"name": "front", "type": "camera", "camera": "front", "width": W, "height": H}
    out = rig([sensor]).read()
    info = out["/front/camera_info"]
    assert info["k"][4] == pytest.approx((H / 2) / math.tan(math.radians(45) / 2))
    image = _rgb(out["/front/image_raw"])
    assert image[H // 2, W // 2, 1] > 200  # the cube is ahead of the MJCF camera too


def test_record_compressed_records_the_png_instead_of_the_raw_image(rig) -> None:
    suite = rig([dict(CAMERA, type="camera", record="compressed")]).suite
    recorded = {o.topic: o.record for s in suite.sensors for o in s.outputs}
    assert recorded == {
        "/cam/image_raw": False,
        "/cam/image_raw/compressed": True,
        "/cam/camera_info": True,
    }
