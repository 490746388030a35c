"""Safe XML parsing for every model format (URDF, SRDF, SDF, MJCF scenes).

Entities are never resolved and the network is never touched; any document that declares
entities is refused outright (libxml2 expands entities in attribute values even with
``resolve_entities=False``, so a billion-laughs file must not reach the parser). Files larger
than :data:`MAX_XML_BYTES` are refused before they are read.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.errors import XMLError

__all__ = [
    "MAX_XML_BYTES",
    "check_size",
    "describe",
    "parse_xml",
    "parse_xml_kept",
    "read_xml_file",
]

MAX_XML_BYTES = 32 * 2**20
"""The largest robot, world or mesh XML file read (32 MiB; real URDF/SDF files are far
smaller, meshes belong in mesh files)."""


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        huge_tree=False,
        remove_comments=True,
        remove_pis=True,
        load_dtd=False,
    )


def parse_xml(data: bytes, source: str) -> etree._Element:
    """Parse ``data`` (named ``source`` in errors) and return the root element.

    Raises :class:`XMLError` with the line for malformed XML, and refuses documents that
    declare entities.
    """
    if b"<!ENTITY" in data:
        raise XMLError(f"{source}: entity declarations are not allowed (unsafe XML refused)")
    try:
        root = etree.fromstring(data, _parser())
    except etree.XMLSyntaxError as exc:
        raise XMLError(f"{source}:{exc.lineno}: malformed XML: {exc.msg}") from None
    dtd = root.getroottree().docinfo.internalDTD
    if dtd is not None and any(True for _ in dtd.iterentities()):
        raise XMLError(f"{source}: entity declarations are not allowed (unsafe XML refused)")
    return root


@lru_cache(maxsize=32)
def parse_xml_kept(data: bytes, source: str) -> etree._Element:
    """:func:`parse_xml`, kept per content and name for the next reader of the same robot
    (every session and ``harness explore`` example reads its robot's files again). For
    readers that never change the tree; a document that does not parse is not kept."""
    return parse_xml(data, source)


def read_xml_file(path: str | Path) -> tuple[etree._Element, bytes]:
    """Read and safely parse the file at ``path``: ``(root element, raw bytes)``."""
    check_size(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise XMLError(f"{path}: cannot read: {exc.strerror or exc}") from None
    return parse_xml(data, str(path)), data


def check_size(path: str | Path, limit: int = MAX_XML_BYTES) -> None:
    """Refuse a file larger than ``limit`` bytes before reading it (:class:`XMLError`)."""
    try:
        size = Path(path).stat().st_size
    except OSError as exc:
        raise XMLError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if size > limit:
        raise XMLError(
            f"{path}: file is {size / 2**20:.1f} MiB, more than the {limit / 2**20:g} MiB "
            "limit for XML files"
        )


def describe(element: etree._Element) -> str:
    """``line N: <tag name="...">`` for error messages."""
    name = element.get("name")
    tag = f'<{element.tag} name="{name}">' if name is not None else f"<{element.tag}>"
    return f"line {element.sourceline}: {tag}" if element.sourceline else tag
