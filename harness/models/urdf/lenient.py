"""Lenient reading of robot files: what urdfdom, Gazebo and PyBullet load, the harness loads.

Real robot files carry defects those readers tolerate: an XML declaration with a version other
than 1.0 (``<?xml version="0.0"?>``), content after the root element (a second copy, a stray
tag), a joint whose two limits are equal (a fixed joint in disguise), a ``<mimic>`` naming a
joint that does not exist. Each is recovered with a :class:`LoadNote` saying what was changed
and where; ``strict=True`` refuses instead. Unexpanded xacro (``$(arg ...)``, ``${...}``) is
never guessed at: it is an error saying the file must be expanded first.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import NamedTuple

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.errors import ModelStructureError, ModelWarning, XMLError
from harness.models.files.xmlsafe import check_size, describe, parse_xml

__all__ = [
    "LoadNote",
    "check_no_xacro",
    "equal_limit_joints",
    "lenient_urdf",
    "read_lenient_xml",
    "warn_notes",
]


class LoadNote(NamedTuple):
    """One thing a lenient load recovered or repaired: ``where`` (file and element) and
    ``what`` (what was wrong and what was done)."""

    where: str
    what: str

    def __str__(self) -> str:
        return f"{self.where}: {self.what}"


_DECLARATION = re.compile(rb"^\s*<\?xml[^>]*\?>", re.S)
_VERSION = re.compile(rb"""version\s*=\s*["']([^"']*)["']""")
_FIRST_TAG = re.compile(rb"<([A-Za-z_][\w:.-]*)")
_XACRO = re.compile(r"\$\((arg|find|env|optenv|eval|dirname)\b[^)]*\)|\$\{[^}]*\}")


def _recover_declaration(data: bytes) -> tuple[bytes, str | None]:
    match = _DECLARATION.match(data)
    if match is None:
        return data, None
    version = _VERSION.search(match.group(0))
    if version is None or version.group(1) == b"1.0":
        return data, None
    fixed = data[: match.start()] + b'<?xml version="1.0"?>' + data[match.end() :]
    return fixed, (
        f'XML declaration says version="{version.group(1).decode(errors="replace")}"; '
        "read as XML 1.0"
    )


def _strip_trailing(data: bytes) -> tuple[bytes, str | None]:
    """Cut everything after the first closing tag of the root element."""
    body = _DECLARATION.sub(b"", data, count=1)
    offset = len(data) - len(body)
    match = _FIRST_TAG.search(re.sub(rb"<!--.*?-->", b"", body, flags=re.S))
    if match is None:
        return data, None
    name = match.group(1)
    close = re.search(rb"</" + re.escape(name) + rb"\s*>", body)
    if close is None:
        return data, None
    end = offset + close.end()
    trailing = data[end:]
    if not trailing.strip():
        return data, None
    line = data[:end].count(b"\n") + 1
    return data[:end] + b"\n", (
        f"{len(trailing.strip())} bytes of content after the root element </"
        f"{name.decode(errors='replace')}> (line {line}) ignored"
    )


def read_lenient_xml(
    path: str | Path, *, strict: bool = False
) -> tuple[etree._Element, bytes, tuple[LoadNote, ...]]:
    """Read and safely parse ``path`` like :func:`harness.models.files.xmlsafe.read_xml_file`,
    recovering a wrong XML declaration version and content after the root element.

    Returns ``(root, raw bytes as read, notes)``. With ``strict`` (or when the recovered text
    still does not parse) the original error is raised.
    """
    check_size(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise XMLError(f"{path}: cannot read: {exc.strerror or exc}") from None
    source = str(path)
    try:
        return parse_xml(data, source), data, ()
    except XMLError as exc:
        if strict:
            raise
        original = exc
    fixed, notes = data, []
    for recover in (_recover_declaration, _strip_trailing):
        fixed, what = recover(fixed)
        if what is not None:
            notes.append(LoadNote(source, what))
    if not notes:
        raise original
    try:
        root = parse_xml(fixed, source)
    except XMLError:
        raise original from None
    return root, data, tuple(notes)


def check_no_xacro(root: etree._Element, source: str) -> None:
    """Raise :class:`ModelStructureError` when the document still holds xacro: an
    ``xacro:`` element or a ``$(arg ...)`` / ``${...}`` expression in an attribute."""
    for element in root.iter():
        if not isinstance(element.tag, str):
            continue
        tag = element.tag
        if tag.startswith("{") and "xacro" in tag.split("}")[0]:
            raise ModelStructureError(
                f"{source}: {describe(element)}: unexpanded xacro element; expand the file "
                "first (load the .xacro, or run xacro) instead of loading it as URDF"
            )
        for attr, value in element.attrib.items():
            match = _XACRO.search(value)
            if match:
                raise ModelStructureError(
                    f"{source}: {describe(element)}: {attr}={value!r} holds the unexpanded "
                    f"xacro expression {match.group(0)!r}; expand the file first (load the "
                    ".xacro, or run xacro) instead of loading it as URDF"
                )


def equal_limit_joints(root: etree._Element) -> list[etree._Element]:
    """The revolute/prismatic ``<joint>`` elements whose lower and upper limits are equal."""
    found = []
    for joint in root.findall("joint"):
        if joint.get("type") not in ("revolute", "prismatic"):
            continue
        limit = joint.find("limit")
        if limit is None:
            continue
        lower, upper = limit.get("lower"), limit.get("upper")
        try:
            if lower is not None and upper is not None and float(lower) == float(upper):
                found.append(joint)
        except ValueError:
            continue
    return found


def warn_notes(notes: Iterable[LoadNote | str]) -> None:
    """Issue each note as one :class:`ModelWarning`."""
    for note in notes:
        warnings.warn(str(note), ModelWarning, stacklevel=3)


def lenient_urdf(root: etree._Element, source: str, *, strict: bool = False) -> list[LoadNote]:
    """Fix, in place, the URDF defects urdfdom tolerates, one note each: a revolute or
    prismatic joint with equal limits becomes a fixed joint; a ``<mimic>`` of a joint that
    does not exist is dropped (the joint moves on its own). Unexpanded xacro is refused.
    ``strict`` refuses the defects instead (:class:`ModelStructureError`)."""
    check_no_xacro(root, source)
    notes: list[LoadNote] = []
    for joint in equal_limit_joints(root):
        limit = joint.find("limit")
        assert limit is not None
        what = f"lower and upper limits are both {limit.get('lower')}: read as a fixed joint"
        if strict:
            raise ModelStructureError(f"{source}: {describe(joint)}: {what.split(':')[0]}")
        notes.append(LoadNote(f"{source}: {describe(joint)}", what))
        joint.set("type", "fixed")
    names = {j.get("name") for j in root.findall("joint")}
    for joint in root.findall("joint"):
        mimic = joint.find("mimic")
        if mimic is None or mimic.get("joint") in names or not mimic.get("joint"):
            continue
        what = f"mimics unknown joint {mimic.get('joint')!r}"
        if strict:
            raise ModelStructureError(f"{source}: {describe(joint)}: {what}")
        notes.append(LoadNote(f"{source}: {describe(joint)}", f"{what}: <mimic> ignored"))
        joint.remove(mimic)
    return notes
