"""Bit equality of arrays: the one definition of "reproduced exactly" used by the simulation's
inputs, replay and its reports. It imports only numpy (not MuJoCo), so a recording can be read
without the simulation.

Bit for bit means ``-0.0`` differs from ``0.0`` (MuJoCo keeps the sign in the state) and two
NaNs are equal only with the same payload; shapes and dtypes must match too.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["differing", "same_bits"]


def same_bits(a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    """Whether ``a`` and ``b`` have the same shape, dtype and bytes (any memory layout)."""
    x, y = np.asarray(a), np.asarray(b)
    return x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()


def differing(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Element by element (flattened, same size and dtype): do the two differ in any bit?"""
    x = np.ascontiguousarray(a).reshape(-1)
    y = np.ascontiguousarray(b).reshape(-1)
    if x.shape != y.shape or x.dtype != y.dtype:
        raise ValueError(f"cannot compare {x.dtype}[{x.size}] with {y.dtype}[{y.size}] bitwise")
    width = x.dtype.itemsize
    out: npt.NDArray[np.bool_] = (
        x.view(np.uint8).reshape(-1, width) != y.view(np.uint8).reshape(-1, width)
    ).any(axis=1)
    return out
