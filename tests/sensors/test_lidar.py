"""A lidar on the rig facing the wall whose face is 2.95 m away along -y."""

from __future__ import annotations

import math

import numpy as np
import pytest

WALL = 2.95
FACING_WALL = [0, 0, 0, 0, 0, -math.pi / 2]
LIDAR = {
    "name": "scan",
    "type": "lidar",
    "parent": "mount",
    "pose": FACING_WALL,
    "samples": 61,
    "min_angle": -1.4,
    "max_angle": 1.4,
    "range_min": 0.1,
    "range_max": 5.0,
}


def _ranges(msg: dict) -> np.ndarray:
    return np.array([math.inf if r is None else r for r in msg["ranges"]])


def test_ranges_to_a_wall_within_a_centimetre_and_inf_out_of_range(rig) -> None:
    scan = rig([LIDAR]).read()["/scan/scan"]
    angles = np.linspace(-1.4, 1.4, 61)
    assert scan["angle_increment"] == pytest.approx(2.8 / 60)
    assert scan["header"]["frame_id"] == "scan"
    ranges = _ranges(scan)
    expected = WALL / np.cos(angles)
    in_range = expected <= 5.0
    assert np.abs(ranges[in_range] - expected[in_range]).max() < 0.01
    assert in_range.sum() < 61  # some rays reach past range_max...
    assert np.isinf(ranges[~in_range]).all()  # ...and read inf


def test_noise_has_the_configured_mean_and_stddev(rig) -> None:
    noisy = dict(LIDAR, name="noisy", noise_mean=0.02, noise_stddev=0.05, samples=360,
                 min_angle=-0.5, max_angle=0.5)  # fmt: skip
    r = rig([dict(noisy, name="clean", noise_mean=0.0, noise_stddev=0.0), noisy], seed=7)
    residuals = []
    for step in range(0, 50, 5):  # 10 Hz at 2 ms steps: every 50th step is due; ask each
        out = {d.output.topic: d for d in r.suite.due(r.data, step * 10, step * 10 * r.dt_ns)}
        clean = _ranges(out["/clean/scan"].build())
        residuals.append(_ranges(out["/noisy/scan"].build()) - clean)
    res = np.concatenate(residuals)
    assert res.size == 3600
    assert res.mean() == pytest.approx(0.02, abs=0.005)
    assert res.std() == pytest.approx(0.05, rel=0.08)


def test_same_seed_same_noise_other_seed_other_noise(rig) -> None:
    noisy = dict(LIDAR, noise_stddev=0.05)
    a = _ranges(rig([noisy], seed=3).read(50)["/scan/scan"])
    b = _ranges(rig([noisy], seed=3).read(50)["/scan/scan"])
    c = _ranges(rig([noisy], seed=4).read(50)["/scan/scan"])
    assert np.array_equal(a, b)
    finite = np.isfinite(a) & np.isfinite(c)
    assert not np.array_equal(a[finite], c[finite])


def test_3d_lidar_publishes_a_point_cloud_on_the_wall(rig) -> None:
    lidar3d = dict(LIDAR, vertical_samples=5, vertical_min_angle=-0.2, vertical_max_angle=0.2)
    cloud = rig([lidar3d]).read()["/scan/points"]
    assert (cloud["height"], cloud["width"]) == (5, 61)
    points = np.frombuffer(cloud["data"], "<f4").reshape(-1, 3)
    hits = points[np.isfinite(points).all(axis=1)]
    assert len(hits) > 100
    # in the sensor frame (x forward = towards the wall): every hit is on the wall plane
    assert np.abs(hits[:, 0] - WALL).max() < 0.01
