"""Contact extraction as arrays (no per-contact Python work beyond the normal force).

After ``mj_step`` the contacts in ``data`` describe the state *before* that step's
integration (MuJoCo computes collisions at the start of the step).
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

__all__ = ["ContactSet", "extract_contacts", "normal_forces"]

_EMPTY_I = np.zeros(0, dtype=np.int32)
_EMPTY_F = np.zeros(0, dtype=np.float64)
_EMPTY_3 = np.zeros((0, 3), dtype=np.float64)
_FEW = 16  # contacts up to which normal forces are read one by one
_PYRAMIDAL = int(mujoco.mjtCone.mjCONE_PYRAMIDAL)


class ContactSet(NamedTuple):
    """Active contacts of one step, one row per contact (all arrays share length ``n``).

    ``depth`` is penetration (``-dist``; negative for contacts inside the margin but not yet
    touching); ``normal_force`` is 0 for contacts without a constraint force (excluded ones).
    Geom and body ids index ``model.geom``/``model.body``.
    """

    geom1: npt.NDArray[np.int32]
    geom2: npt.NDArray[np.int32]
    body1: npt.NDArray[np.int32]
    body2: npt.NDArray[np.int32]
    depth: npt.NDArray[np.float64]
    normal_force: npt.NDArray[np.float64]
    position: npt.NDArray[np.float64]
    normal: npt.NDArray[np.float64]

    @property
    def size(self) -> int:
        """Number of contacts."""
        return int(self.geom1.shape[0])

    @staticmethod
    def empty() -> ContactSet:
        return ContactSet(
            _EMPTY_I, _EMPTY_I, _EMPTY_I, _EMPTY_I, _EMPTY_F, _EMPTY_F, _EMPTY_3, _EMPTY_3
        )


def extract_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> ContactSet:
    """The active contacts of ``data`` as a :class:`ContactSet`."""
    n = int(data.ncon)
    if n == 0:
        return ContactSet.empty()
    contact = data.contact
    geoms = contact.geom.T.astype(np.int32, order="C")  # a copy: data changes next step
    bodies = model.geom_bodyid[geoms]  # both sides in one pass: rows are contiguous views
    return ContactSet(
        geom1=geoms[0],
        geom2=geoms[1],
        body1=bodies[0],
        body2=bodies[1],
        depth=-contact.dist,
        normal_force=normal_forces(model, data, contact.efc_address),
        position=contact.pos.copy(),
        normal=contact.frame[:, :3].copy(),
    )


def normal_forces(
    model: mujoco.MjModel, data: mujoco.MjData, efc_address: npt.NDArray[np.int32]
) -> npt.NDArray[np.float64]:
    """Each contact's normal force (0 without a constraint row), bit for bit
    ``mj_contactForce(...)[0]``: with an elliptic cone the first row's force; with a pyramidal
    one ``0 + f_0 + f_1 + ...`` over the ``2 (dim - 1)`` edges in this order (MuJoCo's
    ``mju_decodePyramid``). Few contacts, rows missing or dims that differ: one contact at a
    time through ``mj_contactForce`` (cheaper than the array passes up to :data:`_FEW`)."""
    if efc_address.shape[0] <= _FEW:
        return _one_by_one(model, data, efc_address.tolist())
    if efc_address.min() < 0:
        return _one_by_one(model, data, efc_address.tolist())
    efc = data.efc_force
    if model.opt.cone != _PYRAMIDAL:
        return np.asarray(efc[efc_address], dtype=np.float64)
    dims = data.contact.dim
    dim = int(dims[0])
    if dim == 1 or not bool((dims == dim).all()):
        return _one_by_one(model, data, efc_address.tolist())
    force: npt.NDArray[np.float64] = 0.0 + efc[efc_address]
    for j in range(1, 2 * (dim - 1)):
        force += efc[efc_address + j]
    return force


def _one_by_one(
    model: mujoco.MjModel, data: mujoco.MjData, adr: list[int]
) -> npt.NDArray[np.float64]:
    force = [0.0] * len(adr)
    f6 = np.zeros(6, dtype=np.float64)
    for i, a in enumerate(adr):
        if a >= 0:
            mujoco.mj_contactForce(model, data, i, f6)
            force[i] = float(f6[0])
    return np.array(force, dtype=np.float64)
