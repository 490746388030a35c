"""Pose algebra of the format-independent robot description."""

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from harness.models.description import Pose

angles = st.floats(-math.pi, math.pi)
coords = st.floats(-10, 10)
poses = st.builds(
    lambda x, y, z, r, p, w: Pose.from_xyz_rpy((x, y, z), (r, p, w)),
    coords,
    coords,
    coords,
    angles,
    st.floats(-1.5, 1.5),
    angles,
)


@given(poses, poses)
def test_composition_matches_matrices(a: Pose, b: Pose) -> None:
    assert np.allclose((a * b).matrix(), a.matrix() @ b.matrix(), atol=1e-12)


@given(poses)
def test_inverse_and_matrix_round_trip(a: Pose) -> None:
    assert (a * a.inverse()).is_close(Pose.identity(), atol=1e-12)
    assert Pose.from_matrix(a.matrix()).is_close(a, atol=1e-12)


def test_rpy_is_fixed_axis_zyx() -> None:
    pose = Pose.from_xyz_rpy((0, 0, 0), (0.1, 0.2, 0.3))
    rx = Pose.from_xyz_rpy((0, 0, 0), (0.1, 0, 0)).rotation_matrix()
    ry = Pose.from_xyz_rpy((0, 0, 0), (0, 0.2, 0)).rotation_matrix()
    rz = Pose.from_xyz_rpy((0, 0, 0), (0, 0, 0.3)).rotation_matrix()
    assert np.allclose(pose.rotation_matrix(), rz @ ry @ rx)
    assert np.allclose(pose.rpy(), (0.1, 0.2, 0.3))
    assert pose.as_list()[:3] == [0.0, 0.0, 0.0]
