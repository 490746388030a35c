"""The joint readings a controller is given: read on first use (:class:`Snapshot`), or none
for a controller that declares it never reads them (:data:`UNREAD`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["UNREAD", "Snapshot"]


class Snapshot(Mapping[str, float]):
    """Joint name -> value of an array read on first use (then held: the same values a dict
    built at once would hold). It also gives the whole array (:meth:`array`, in the order of
    :attr:`names`: a :class:`harness.controllers.JointArray`), so that a controller over many
    joints takes them in one go instead of one look per joint."""

    __slots__ = ("_array", "_dict", "_read", "names")

    def __init__(self, names: Sequence[str], read: Callable[[], npt.NDArray[np.float64]]) -> None:
        self.names = names
        """The joints, in the order of :meth:`array`."""
        self._read = read
        self._array: npt.NDArray[np.float64] | None = None
        self._dict: dict[str, float] | None = None

    def array(self) -> npt.NDArray[np.float64]:
        """Every joint's value (read on first use, then held: read it, never write it)."""
        a = self._array
        if a is None:
            a = self._array = self._read()
        return a

    def _get(self) -> dict[str, float]:
        d = self._dict
        if d is None:
            d = self._dict = dict(zip(self.names, self.array().tolist(), strict=True))
        return d

    def __getitem__(self, key: str) -> float:
        d = self._dict
        return (self._get() if d is None else d)[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __contains__(self, key: object) -> bool:
        return key in self._get()

    def __eq__(self, other: object) -> bool:
        return self._get() == (other._get() if isinstance(other, Snapshot) else other)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return repr(self._get())


class Unread(Mapping[str, float]):
    """The joint readings given to a controller that declares it never reads them
    (``reads_state = False``): any look raises, so a wrong declaration shows."""

    __slots__ = ()

    def _refuse(self) -> RuntimeError:
        return RuntimeError(
            "this controller declares reads_state = False: it is given no joint readings"
        )

    def __getitem__(self, key: str) -> float:
        raise self._refuse()

    def __iter__(self) -> Iterator[str]:
        raise self._refuse()

    def __len__(self) -> int:
        raise self._refuse()

    def __contains__(self, key: object) -> bool:
        raise self._refuse()

    def __repr__(self) -> str:
        return "<unread>"


UNREAD = Unread()
