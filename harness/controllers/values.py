"""A controller's joints read out of :class:`~harness.controllers.base.JointReadings` at once.

The session gives each controller update the robot's joint readings as mappings (joint ->
value). A controller over many joints reads them every cycle; :class:`JointIndex` takes its
joints' values in one go from a mapping that also offers the whole array
(:class:`JointArray`: the session's readings do), through an index computed once per robot, and
falls back to one look per joint for any other mapping (a test's dict). Both give the same
Python floats, bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

__all__ = ["JointArray", "JointIndex"]


class JointArray(Protocol):
    """Joint readings that also give every value at once: ``array()[i]`` is the value of
    ``names[i]`` (the array is shared: read it, never write it)."""

    @property
    def names(self) -> Sequence[str]: ...

    def array(self) -> npt.NDArray[np.float64]: ...


class JointIndex:
    """Takes the values of ``joints`` (in that order) out of joint readings; the index into a
    :class:`JointArray` is computed for the first readings of a set of names and kept while
    the readings carry the same ``names`` object (a robot's names do not change)."""

    __slots__ = ("_index", "_names", "joints")

    def __init__(self, joints: Sequence[str]) -> None:
        self.joints = tuple(joints)
        self._names: Sequence[str] | None = None
        self._index: slice | npt.NDArray[np.intp] | None = None

    def _index_of(self, names: Sequence[str]) -> slice | npt.NDArray[np.intp] | None:
        where = {name: i for i, name in enumerate(names)}
        rows = [where.get(joint, -1) for joint in self.joints]
        if -1 in rows:
            return None  # a joint the readings lack: each look raises as the mapping does
        if rows == list(range(rows[0], rows[0] + len(rows))):
            return slice(rows[0], rows[0] + len(rows))
        return np.array(rows, dtype=np.intp)

    def take(self, readings: Mapping[str, float]) -> list[float]:
        """The values of :attr:`joints` in ``readings`` (a ``KeyError`` for a joint it lacks)."""
        array = getattr(readings, "array", None)
        if array is not None:
            names = readings.names  # type: ignore[attr-defined]
            if names is not self._names:
                self._index = self._index_of(names) if self.joints else None
                self._names = names
            index = self._index
            if index is not None:
                values: list[float] = array()[index].tolist()
                return values
        return [readings[joint] for joint in self.joints]
