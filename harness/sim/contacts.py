"""Contact extraction as arrays (no per-contact Python work beyond the normal force).

After ``mj_step`` the contacts in ``data`` describe the state *before* that step's
integration (MuJoCo computes collisions at the start of the step).
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

__all__ = ["ContactSet", "extract_contacts"]

_EMPTY_I = np.zeros(0, dtype=np.int32)
_EMPTY_F = np.zeros(0, dtype=np.float64)
_EMPTY_3 = np.zeros((0, 3), dtype=np.float64)


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
    geoms = np.asarray(contact.geom[:n], dtype=np.int32)
    geom1 = geoms[:, 0].copy()
    geom2 = geoms[:, 1].copy()
    bodies = model.geom_bodyid
    force = np.zeros(n, dtype=np.float64)
    f6 = np.zeros(6, dtype=np.float64)
    efc = contact.efc_address[:n]
    for i in np.flatnonzero(efc >= 0):
        mujoco.mj_contactForce(model, data, int(i), f6)
        force[i] = f6[0]
    return ContactSet(
        geom1=geom1,
        geom2=geom2,
        body1=bodies[geom1].astype(np.int32),
        body2=bodies[geom2].astype(np.int32),
        depth=-np.asarray(contact.dist[:n], dtype=np.float64),
        normal_force=force,
        position=np.array(contact.pos[:n], dtype=np.float64),
        normal=np.array(contact.frame[:n, :3], dtype=np.float64),
    )
