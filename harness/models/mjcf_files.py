"""MJCF file references confined like ``package://`` references: checked before MuJoCo reads.

MuJoCo's parser opens ``<include file>`` itself and its compiler opens meshes, textures, height
fields, skins and ``<model file>`` sub-models; a file from elsewhere could name ``/etc/...`` or
``../../secret`` and have its bytes end up in a recording's attachments. So before
:meth:`mujoco.MjSpec.from_file` sees an MJCF file, :func:`check_mjcf_files` walks it (and its
includes, each read with the safe XML reader) and refuses, with one :class:`ResolveError`
line naming the file and element, any reference whose real path (``..`` and symlinks
resolved) leaves the model's folder: the folder of the top-level file, or the ROS package it
lies in (the nearest folder above it with a ``package.xml``), the folder a ``package://``
reference is confined to; the harness's own scene data is always allowed (a generated scene
points there). Absolute references are refused unless they lie inside too.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path

from lxml import etree

from harness.models.confine import confinement
from harness.models.errors import OutsideReferenceError, ResolveError
from harness.models.xmlsafe import describe, read_xml_file

__all__ = ["MAX_INCLUDES", "check_mjcf_files", "generated_from", "mjcf_roots"]

MAX_INCLUDES = 1000
"""Most ``<include>`` elements one model may have, all files together (a cycle ends here)."""

_FILE_ATTRIBUTES = (
    "file",
    "fileright",
    "fileleft",
    "fileup",
    "filedown",
    "filefront",
    "fileback",
)
_DIR_ATTRIBUTES = ("meshdir", "texturedir", "assetdir")


_GENERATED: dict[Path, tuple[Path, ...]] = {}
_OWN_DATA = Path(__file__).resolve().parent / "data"  # the scenes and meshes the harness ships


def generated_from(generated: str | Path, source: str | Path) -> None:
    """Record that the harness wrote MJCF file ``generated`` from ``source`` (already
    checked), keeping its references: ``generated`` may reach what ``source`` may."""
    _GENERATED[Path(generated).resolve()] = mjcf_roots(source)


def mjcf_roots(path: str | Path) -> tuple[Path, ...]:
    """The folders ``path``'s references may lead into (real paths): its own folder and the
    ROS package it lies in, if any (for a file the harness generated: its source's)."""
    generated = _GENERATED.get(Path(path).resolve())
    if generated is not None:
        return generated
    confined = confinement()
    if confined is not None:  # a rebuild from a recording: its own folder only
        return (confined, _OWN_DATA)
    folder = Path(path).resolve().parent
    for above in (folder, *folder.parents):
        if (above / "package.xml").is_file():
            return (folder, above, _OWN_DATA) if above != folder else (folder, _OWN_DATA)
    return (folder, _OWN_DATA)


def _real(path: Path) -> Path:
    """``path`` with ``..`` and symbolic links resolved; in a rebuild from a recording
    (:mod:`harness.models.confine`) on the text only: no file outside is looked at."""
    if confinement() is not None:
        return Path(os.path.normpath(os.path.join(os.getcwd(), path)))
    return path.resolve()


def _inside(path: Path, roots: Sequence[Path]) -> bool:
    real = _real(path)
    return any(real.is_relative_to(root) for root in roots)


def _elements(root: etree._Element) -> Iterator[etree._Element]:
    for element in root.iter():
        if isinstance(element.tag, str):
            yield element


def check_mjcf_files(path: str | Path, roots: Sequence[Path] | None = None) -> None:
    """Raise :class:`ResolveError` when MJCF file ``path`` or one of its includes references
    a file outside ``roots`` (default :func:`mjcf_roots`)."""
    top = Path(path)
    allowed = tuple(roots) if roots is not None else mjcf_roots(top)
    base = top.resolve().parent
    folders = [base]  # where relative references may be looked up (compiler directories)
    pending: list[tuple[Path, etree._Element]] = [(top, read_xml_file(top)[0])]
    includes = 0
    while pending:
        source, tree = pending.pop()
        elements = list(_elements(tree))
        for element in elements:
            for attribute in _DIR_ATTRIBUTES:
                value = element.get(attribute)
                if value:
                    # A compiler directory is checked through the files looked up in it: one
                    # no file uses opens nothing (a generated scene's absolute meshdir, recorded
                    # on another machine, names a folder that exists only there).
                    folders.append(base / value)
        for element in elements:
            for attribute in _FILE_ATTRIBUTES:
                value = element.get(attribute)
                if not value:
                    continue
                if element.tag == "include":
                    candidates = [base / value, source.resolve().parent / value]
                else:
                    candidates = [folder / value for folder in folders]
                _check(source, element, attribute, value, candidates, allowed)
                if element.tag == "include" and attribute == "file":
                    includes += 1
                    if includes > MAX_INCLUDES:
                        raise ResolveError(
                            f"{source}: more than {MAX_INCLUDES} <include> elements "
                            "(an include cycle?)"
                        )
                    found = next((c for c in candidates if c.is_file()), None)
                    if found is not None:
                        pending.append((found, read_xml_file(found)[0]))


def _check(
    source: Path,
    element: etree._Element,
    attribute: str,
    value: str,
    candidates: Sequence[Path],
    roots: Sequence[Path],
) -> None:
    for candidate in candidates:
        if not _inside(candidate, roots):
            where = " or ".join(repr(str(r)) for r in roots)
            error = OutsideReferenceError if confinement() is not None else ResolveError
            raise error(
                f"{source}: {describe(element)}: {attribute}={value!r} escapes the model's "
                f"folder {where} (it leads to {str(_real(candidate))!r})"
            )
