"""Model loading confined to one folder: what a rebuild from a recording may read.

A recording is data from someone else (README "Trust"). When replay rebuilds a model from its
source attachments, it writes them into a fresh private folder and loads the model inside
:func:`confined_to` that folder. While confined, every file reference a loader resolves
(URDF and SDF mesh URIs, ``package://``, ``model://``, ``file://``, absolute and relative
paths, SDF ``<include>``, MJCF ``file``/``meshdir``/``texturedir``/``<include>``) must lie
inside the folder, decided on the path's text (``..`` folded, no file looked at): anything
else is an :class:`~harness.models.errors.OutsideReferenceError` whose text names only the
reference, so it is the same whether that path exists on this machine or not. Package and
model searches use only the folder (no ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH`` or Gazebo
resource paths, no folder above it), and a xacro file is never expanded. The harness's own
data (its bundled scenes, demo robot and Gazebo models: part of the installed program, not
of this machine's other files) stays readable.

The folder must be one the caller wrote itself from bytes (no symbolic links in it): the
containment test is textual, which is exact only then.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path

from harness.models.bundled import DATA
from harness.models.errors import OutsideReferenceError

__all__ = ["check_confined", "confined_to", "confinement", "inside_confinement"]

_ROOT: ContextVar[Path | None] = ContextVar("harness_models_confinement", default=None)
_OWN_DATA = Path(os.path.abspath(DATA))
_TRUSTED = tuple({_OWN_DATA, Path(os.path.realpath(_OWN_DATA))})


@contextlib.contextmanager
def confined_to(root: str | Path) -> Iterator[Path]:
    """Within this block (this thread or task), model loading reads only inside ``root``
    (see the module docstring); yields the folder's real path."""
    real = Path(os.path.realpath(root))
    token = _ROOT.set(real)
    try:
        yield real
    finally:
        _ROOT.reset(token)


def confinement() -> Path | None:
    """The folder loading is confined to, or None."""
    return _ROOT.get()


def _folded(path: str | Path) -> Path:
    return Path(os.path.normpath(os.path.join(os.getcwd(), os.fspath(path))))


def inside_confinement(path: str | Path) -> bool:
    """Whether ``path`` (text only: ``..`` folded, nothing looked up) lies inside the
    confinement folder (or the harness's own data); always True when not confined."""
    root = _ROOT.get()
    if root is None:
        return True
    folded = _folded(path)
    return any(folded.is_relative_to(folder) for folder in (root, *_TRUSTED))


def check_confined(
    path: str | Path, reference: str, *, context: str = "", what: str = "file"
) -> None:
    """Raise :class:`OutsideReferenceError` when loading is confined and ``path`` (what
    ``reference`` leads to) is outside the folder; the message names ``reference`` only."""
    if inside_confinement(path):
        return
    prefix = f"{context}: " if context else ""
    raise OutsideReferenceError(
        f"{prefix}{what} reference {reference!r} is outside the recording: a model is rebuilt "
        "only from the recording's own attachments"
    )
