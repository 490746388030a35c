"""Inertia tensors on the edge of validity, handed to MuJoCo so that its rounding never
refuses what the readers accepted.

A thin disc (a wheel: A + B = C exactly) is a valid inertia, and the readers accept it; MuJoCo's
compiler diagonalises a full tensor itself and checks the triangle inequality exactly on the
result, so a rounding error of 1e-20 makes it refuse the file (or, with ``balanceinertia``,
replace the wheel's moments by their mean). :func:`principal_on_edge` gives such a tensor as
principal moments (the largest lowered to the sum of the others: a change at the rounding
level) and axes; :func:`settle_edge_inertias` does it for every body of a spec.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["EDGE", "principal_on_edge", "settle_edge_inertias"]

EDGE = 1e-9
"""Relative margin: moments whose A + B - C is within ``EDGE * C`` of zero are on the edge."""
_MIN_MOMENT = 1e-8


def principal_on_edge(
    tensor: np.ndarray, *, welded: bool = False
) -> tuple[list[float], list[float]] | None:
    """Principal moments and axes (a quaternion w x y z) to hand MuJoCo instead of ``tensor``,
    or None to hand it over as it is (clearly valid, or clearly invalid: MuJoCo's error names
    the body). A ``welded`` body's invalid tensor (it never moves: Gazebo ignores a static
    model's inertia) gets valid moments, raised as the readers' repair raises them."""
    if not np.all(np.isfinite(tensor)):
        return None
    moments, axes = np.linalg.eigh(tensor)
    slack = moments[0] + moments[1] - moments[2]
    edge = EDGE * abs(moments[2])
    if moments[0] > 0.0 and slack > edge:
        return None
    if welded:
        fixed = np.maximum(moments, _MIN_MOMENT)
        if fixed[0] + fixed[1] < fixed[2]:
            fixed[0] = max(fixed[0], fixed[2] / 2.0)
            fixed[1] = max(fixed[1], fixed[2] / 2.0)
    elif moments[0] > 0.0 and slack >= -edge:
        fixed = moments.copy()
    else:
        return None
    fixed[2] = min(fixed[2], fixed[0] + fixed[1])
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(axes).reshape(9))
    return [float(m) for m in fixed], quat.tolist()


def settle_edge_inertias(spec: mujoco.MjSpec) -> None:
    """Every body of ``spec`` with a full inertia on the edge (see the module docstring) gets
    its principal moments and the matching inertial frame instead."""
    for body in spec.bodies:
        full = np.asarray(body.fullinertia, dtype=float)
        if not body.explicitinertial or not np.isfinite(full[0]):
            continue
        tensor = np.array(
            [
                [full[0], full[3], full[4]],
                [full[3], full[1], full[5]],
                [full[4], full[5], full[2]],
            ]
        )
        principal = principal_on_edge(tensor)
        if principal is None:
            continue
        moments, axes = principal
        frame = np.zeros(4)
        mujoco.mju_mulQuat(frame, np.asarray(body.iquat, dtype=float), np.asarray(axes))
        body.fullinertia = [np.nan] * 6
        body.inertia = moments
        body.iquat = frame.tolist()
