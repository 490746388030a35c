"""Every source file attached once, by content.

A robot's sources name the same bytes under several paths: a xacro robot's meshes are attached
where its ``package://`` references resolve on replay (``source/package/<pkg>/...``) and where a
plain URDF's would (``source/<pkg>/...``, :mod:`harness.recording.meshes`); two robots of a
world load the same URDF; a description references one mesh by two paths. A recording holds
each content once: the first ``source/...`` attachment with those bytes (in attachment order)
carries them, and every later name with the same bytes is listed in the
:data:`ATTACHMENT_SOURCE_LINKS` attachment (JSON object: name under ``source/`` -> the name
under ``source/`` that carries its bytes), never attached itself.

A rebuild lays out every linked name from the bytes of the attachment it names
(:func:`harness.replay.gate.recorded_sources`): each name and its target are checked like any
attachment name, the target must be a ``source/`` attachment of the recording, at most
:data:`MAX_SOURCE_LINKS` links and :data:`MAX_LINKED_BYTES` bytes laid out through them.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Final

from harness.recording.layout import ATTACHMENT_SOURCE_PREFIX

__all__ = [
    "ATTACHMENT_SOURCE_LINKS",
    "ATTACHMENT_SOURCE_REFS",
    "MAX_LINKED_BYTES",
    "MAX_SOURCE_LINKS",
    "PROJECT_REFERENCE_REFUSAL",
    "link_sources",
    "parse_source_links",
]

ATTACHMENT_SOURCE_LINKS: Final = "source-links.json"
"""The attachment listing the source names whose bytes another ``source/`` attachment carries."""

ATTACHMENT_SOURCE_REFS: Final = "source-refs.json"
"""A golden's references to its project's files by content hash instead of attachments
(:mod:`harness.plugin.golden_sources`): resolved only by the pytest golden check."""

PROJECT_REFERENCE_REFUSAL: Final = (
    "a golden that refers to its sources in its project by content hash "
    f"({ATTACHMENT_SOURCE_REFS}, --harness-golden-sources=project) is read only by that "
    "project's pytest golden check; write it with its sources carried to replay, diff or "
    "inspect it elsewhere"
)
"""Why a file with :data:`ATTACHMENT_SOURCE_REFS` is refused outside the golden check."""

MAX_SOURCE_LINKS: Final = 10_000
"""Links a recording may list (a rebuild writes one file per link)."""

MAX_LINKED_BYTES: Final = 1024**3
"""Bytes a rebuild may lay out through links (1 GiB), beyond the attachments themselves."""


def link_sources(attachments: Mapping[str, bytes]) -> dict[str, bytes]:
    """``attachments`` with every ``source/...`` content attached once: a later name with
    the same bytes as an earlier one is dropped and listed in :data:`ATTACHMENT_SOURCE_LINKS`
    (added after the last source attachment; absent when nothing is shared). Other
    attachments and the order are kept."""
    carrier: dict[str, str] = {}
    links: dict[str, str] = {}
    out: dict[str, bytes] = {}
    last_source = -1
    for name, blob in attachments.items():
        if name.startswith(ATTACHMENT_SOURCE_PREFIX):
            digest = hashlib.sha256(blob).hexdigest()
            first = carrier.setdefault(digest, name)
            if first != name:
                links[name.removeprefix(ATTACHMENT_SOURCE_PREFIX)] = first.removeprefix(
                    ATTACHMENT_SOURCE_PREFIX
                )
                continue
            last_source = len(out)
        out[name] = blob
    if not links:
        return out
    text = json.dumps(links, sort_keys=True, indent=0).encode("utf-8")
    items = list(out.items())
    items.insert(last_source + 1, (ATTACHMENT_SOURCE_LINKS, text))
    return dict(items)


def parse_source_links(blob: bytes) -> dict[str, str]:
    """The links of a :data:`ATTACHMENT_SOURCE_LINKS` attachment (name -> carrier, both
    under ``source/``, unchecked); :class:`ValueError` with the reason when it is not a JSON
    object of strings within :data:`MAX_SOURCE_LINKS`."""
    try:
        links = json.loads(blob.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise ValueError(f"not JSON ({' '.join(str(exc).split())})") from None
    if not isinstance(links, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in links.items()
    ):
        raise ValueError("not a JSON object of names")
    if len(links) > MAX_SOURCE_LINKS:
        raise ValueError(f"{len(links)} links, more than the limit of {MAX_SOURCE_LINKS}")
    return links
