"""What one pass over an MCAP file found (:class:`Scan`), and the damage it names.

The records the passes of :mod:`harness.recording.scan` fill in: the chunks that checked out
(:class:`ChunkInfo`), the attachments (:class:`AttachmentInfo`), each defect at its byte
offset (:class:`Problem`), the damaged stretches passed over (:class:`Skipped`) and the
message index entries of chunks still to be checked (:class:`IndexEntries`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from mcap.records import Channel, Header, Metadata, Schema

__all__ = [
    "I64",
    "AttachmentInfo",
    "ChunkInfo",
    "IndexEntries",
    "Problem",
    "Scan",
    "Skipped",
    "problems_text",
]

I64 = npt.NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class Problem:
    """Something wrong in the file, at byte ``offset``."""

    offset: int
    message: str

    def __str__(self) -> str:
        return f"byte {self.offset}: {self.message}"


def problems_text(problems: Sequence[Problem], limit: int = 5) -> str:
    """``problems`` on one line: the first ``limit``, then how many more there are."""
    text = "; ".join(str(p) for p in problems[:limit])
    if len(problems) > limit:
        text += f"; and {len(problems) - limit} more problems (harness inspect lists them)"
    return text


@dataclass(frozen=True, slots=True)
class ChunkInfo:
    """A chunk whose CRC checked out: where it is and what it holds."""

    offset: int
    length: int
    start_time: int
    end_time: int
    channels: frozenset[int]
    messages: int


@dataclass(frozen=True, slots=True)
class AttachmentInfo:
    """An attachment record (its data is read on demand); ``damaged`` says why its bytes
    cannot be trusted ("" when its CRC checked out)."""

    offset: int
    name: str
    media_type: str
    data_offset: int
    data_length: int
    damaged: str = ""


@dataclass(frozen=True, slots=True)
class Skipped:
    """A damaged stretch of the data section passed over, ``[offset, end)``: the messages
    in it are lost; reading went on after it."""

    offset: int
    end: int
    what: str


class IndexEntries(NamedTuple):
    """A chunk's message index entries, in record order: where each record starts in the
    decompressed chunk, its log time, its channel."""

    where: I64
    times: I64
    channels: npt.NDArray[np.uint16]


@dataclass
class Scan:
    """Everything one pass found. ``truncated_at`` is where reading stopped because of damage
    (``None``: the whole data section was readable); ``problems`` lists every defect found."""

    size: int
    header: Header
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunks: list[ChunkInfo] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=dict)
    metadata: list[Metadata] = field(default_factory=list)
    attachments: list[AttachmentInfo] = field(default_factory=list)
    start_time: int = -1
    end_time: int = -1
    problems: list[Problem] = field(default_factory=list)
    truncated_at: int | None = None
    # Damaged chunks (or stretches) passed over: their messages are lost, the rest is read.
    skipped: list[Skipped] = field(default_factory=list)
    data_crc_checked: bool = False
    has_summary: bool = False
    summary_crc_checked: bool = False
    summary_checks: int = 0
    # Chunk offset -> channel id -> byte offsets (ascending) of that channel's message records
    # in the decompressed chunk; filled by index_scan only.
    message_index: dict[int, dict[int, I64]] = field(default_factory=dict)
    indexed: bool = False
    # Channel id -> log time of its first and of its last message.
    time_ranges: dict[int, tuple[int, int]] = field(default_factory=dict)
    # Chunk offset -> index entries of chunks whose contents are still to be checked (CRC,
    # entries against records): index_scan(check_chunks=False) leaves that to the first read.
    unchecked: dict[int, IndexEntries] = field(default_factory=dict)
    # What the chunks read so far declare they decompress to (bounded: harness.recording.inflate).
    declared_bytes: int = 0
    # Records walked or indexed so far, in the data section and its chunks (bounded likewise).
    records: int = 0
    # Messages whose log time goes back: one problem names the first, with how many in all.
    time_back: int = 0
    time_back_problem: int = -1

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())
