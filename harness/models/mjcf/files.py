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

In a rebuild from a recording (:mod:`harness.models.files.confine`) MuJoCo is given no path at all:
:func:`mjcf_in_memory` reads the file and its includes in Python (each checked first) and
inlines the includes, so MuJoCo parses one string; the compiler's files then reach it as
in-memory assets (:func:`harness.models.files.assets.embed_files`).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path

from lxml import etree

from harness.models.bundled import DATA
from harness.models.errors import OutsideReferenceError, ResolveError, XMLError
from harness.models.files.confine import confinement
from harness.models.files.xmlsafe import describe, read_xml_file

__all__ = [
    "MAX_INCLUDES",
    "check_mjcf_files",
    "generated_from",
    "mjcf_in_memory",
    "mjcf_roots",
]

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
_OWN_DATA = DATA  # the scenes and meshes the harness ships


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
    (:mod:`harness.models.files.confine`) on the text only: no file outside is looked at."""
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


def _include_file(source: Path, base: Path, element: etree._Element, value: str) -> Path:
    """The file ``<include file=value>`` of ``source`` names, found as MuJoCo finds it (the
    top-level file's folder first, then the including file's), inside the confinement."""
    for candidate in (base / value, source.parent / value):
        if _inside(candidate, mjcf_roots(source)) and candidate.is_file():
            return candidate
    raise OutsideReferenceError(
        f"{source}: {describe(element)}: include file {value!r} is not among the recording's "
        "attachments"
    )


def _inline_includes(
    source: Path, tree: etree._Element, base: Path, seen: list[int]
) -> etree._Element:
    """``tree`` (of file ``source``) with every ``<include>`` replaced by the children of the
    root of the file it names, recursively, as MuJoCo's parser does."""
    for element in [e for e in _elements(tree) if e.tag == "include"]:
        value = element.get("file")
        if not value:
            continue  # MuJoCo's own error, from the string
        seen[0] += 1
        if seen[0] > MAX_INCLUDES:
            raise ResolveError(
                f"{source}: more than {MAX_INCLUDES} <include> elements (an include cycle?)"
            )
        found = _include_file(source, base, element, value)
        included = _inline_includes(found, read_xml_file(found)[0], base, seen)
        parent = element.getparent()
        if parent is None:  # the root itself: MuJoCo refuses it, from the string
            continue
        index = parent.index(element)
        parent.remove(element)
        for offset, child in enumerate(list(included)):
            parent.insert(index + offset, child)
    return tree


def mjcf_in_memory(path: str | Path) -> str:
    """The MJCF file ``path`` as one string for :meth:`mujoco.MjSpec.from_string`: its
    ``<include>`` elements replaced by the files they name (read in Python, each confined and
    checked, see :func:`check_mjcf_files`), so MuJoCo opens no file to parse it. For a
    rebuild from a recording: an include missing from the recording is an
    :class:`OutsideReferenceError`, as is a ``<model file>`` sub-model (MuJoCo would read
    it by its path)."""
    top = Path(path)
    check_mjcf_files(top)
    tree, data = read_xml_file(top)
    includes = [0]
    tree = _inline_includes(top, tree, top.resolve().parent, includes)
    for element in _elements(tree):
        if element.tag == "model" and element.get("file"):
            raise OutsideReferenceError(
                f"{top}: {describe(element)}: a <model file> sub-model is not rebuilt from a "
                "recording"
            )
    if includes[0]:
        return str(etree.tostring(tree, encoding="unicode"))
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise XMLError(f"{top}: not UTF-8 text (byte {exc.start})") from None
