"""Chunk decompression bounded by limits of our own, never by a size the file declares.

A recording may come from someone else: it is data, and reading it must not take more memory
or time than a limit the reader chooses. A chunk's declared uncompressed size (in the MCAP
chunk header, or in the zstd/lz4 frame header) is only a claim: a 143 KB zstd chunk can claim,
and inflate to, 4 GiB. So every chunk is decompressed as a stream into at most
``min(declared, InflateLimits.chunk_bytes)`` bytes (one more byte read says the claim was a
lie), and the declared sizes of one file's chunks add up to at most
``InflateLimits.file_bytes``. Defaults: 1 GiB per chunk (the recorder writes chunks of a few
MiB), 64 GiB per file; the environment variables ``HARNESS_MAX_CHUNK_BYTES`` and
``HARNESS_MAX_FILE_BYTES`` change them (for every reader: ``harness inspect``, ``replay``,
``diff``, :class:`harness.Recording`).

Bytes do not bound the work: a 70 KB zstd chunk inflates to 27 M empty message records,
minutes of walking in Python. So the records are limited too: at most
``InflateLimits.chunk_records`` in one chunk and ``InflateLimits.file_records`` in one file
(``HARNESS_MAX_CHUNK_RECORDS``, ``HARNESS_MAX_FILE_RECORDS``). A walk counts the records of a
chunk as its bytes come out of the decompressor (the ``watch`` of :func:`decompress`) and
stops at the first record over a limit. Defaults: 262,144 records per chunk (the recorder's
1 MiB chunks hold a few hundred: 765 at most in 60 s of the demo scenario; 24 k of the
smallest message it writes would fill one) and 268,435,456 per file (the demo scenario
records about 65,000 messages per minute of simulated time: that is some 69 hours). A file
of empty messages at the per-chunk limit packs about 300 records in a byte: a full walk of
such a file costs about 0.4 µs a record, so the per-file limit bounds it to minutes, not the
hours its bytes alone would allow.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

import zstandard

__all__ = [
    "CHUNK_RECORDS_ENV",
    "DEFAULT_CHUNK_BYTES",
    "DEFAULT_CHUNK_RECORDS",
    "DEFAULT_FILE_BYTES",
    "DEFAULT_FILE_RECORDS",
    "FILE_RECORDS_ENV",
    "InflateError",
    "InflateLimits",
    "current_limits",
    "decompress",
]

DEFAULT_CHUNK_BYTES = 2**30
DEFAULT_FILE_BYTES = 64 * 2**30
DEFAULT_CHUNK_RECORDS = 2**18
DEFAULT_FILE_RECORDS = 2**28
_CHUNK_ENV = "HARNESS_MAX_CHUNK_BYTES"
_FILE_ENV = "HARNESS_MAX_FILE_BYTES"
CHUNK_RECORDS_ENV = "HARNESS_MAX_CHUNK_RECORDS"
"""The environment variable that sets :attr:`InflateLimits.chunk_records`."""
FILE_RECORDS_ENV = "HARNESS_MAX_FILE_RECORDS"
"""The environment variable that sets :attr:`InflateLimits.file_records`."""
_READ_STEP = 4 * 2**20


class InflateError(ValueError):
    """A chunk does not decompress within the limits (or not at all)."""


@dataclass(frozen=True, slots=True)
class InflateLimits:
    """Most bytes one chunk may decompress to, and all chunks of one file together; most
    records one chunk may hold, and one file."""

    chunk_bytes: int = DEFAULT_CHUNK_BYTES
    file_bytes: int = DEFAULT_FILE_BYTES
    chunk_records: int = DEFAULT_CHUNK_RECORDS
    file_records: int = DEFAULT_FILE_RECORDS

    def charge_file(self, total: int) -> None:
        """Raise :class:`InflateError` when a file's chunks declare ``total`` bytes, more
        than :attr:`file_bytes`."""
        if total > self.file_bytes:
            raise InflateError(
                f"the file's chunks declare {total} bytes decompressed in all, over the limit "
                f"of {self.file_bytes} ({_FILE_ENV})"
            )


def _env_count(name: str, default: int, unit: str) -> int:
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value <= 0:
        raise InflateError(f"{name}={text!r}: expected a positive number of {unit}")
    return value


def current_limits() -> InflateLimits:
    """The limits in force: the defaults, or what the environment variables say."""
    return InflateLimits(
        _env_count(_CHUNK_ENV, DEFAULT_CHUNK_BYTES, "bytes"),
        _env_count(_FILE_ENV, DEFAULT_FILE_BYTES, "bytes"),
        _env_count(CHUNK_RECORDS_ENV, DEFAULT_CHUNK_RECORDS, "records"),
        _env_count(FILE_RECORDS_ENV, DEFAULT_FILE_RECORDS, "records"),
    )


def decompress(
    compression: str,
    data: bytes | memoryview,
    declared: int,
    limits: InflateLimits | None = None,
    watch: Callable[[bytes | memoryview], None] | None = None,
) -> bytes:
    """``data`` decompressed, at most ``declared`` bytes (itself at most the chunk limit);
    raises :class:`InflateError` when the claim is over the limit, when the data inflates
    to more than it claims, or when it does not decompress.

    ``watch`` sees the decompressed bytes piece by piece, in order, as they come out (at most
    a few MiB at a time); what it raises stops the decompression and is raised from here."""
    limit = (limits or current_limits()).chunk_bytes
    if declared > limit:
        raise InflateError(
            f"chunk declares {declared} bytes decompressed, over the limit of {limit} "
            f"({_CHUNK_ENV})"
        )
    if compression == "zstd":
        out = _zstd(data, declared, watch)
    elif compression == "lz4":
        out = _lz4(data, declared, watch)
    elif compression == "":
        if watch is not None:
            watch(data[: declared + 1])
        out = bytes(data)
    else:
        raise InflateError(f"unsupported chunk compression {compression!r}")
    if len(out) > declared:
        raise InflateError(f"chunk decompresses to more than the {declared} bytes it declares")
    return out


def _zstd(
    data: bytes | memoryview, bound: int, watch: Callable[[bytes | memoryview], None] | None
) -> bytes:
    # A stream, not ZstdDecompressor.decompress: that allocates what the frame header claims.
    # Pieces of at most _READ_STEP bytes when watched, so that a watch can stop it early.
    step = bound + 1 if watch is None else _READ_STEP
    try:
        reader = zstandard.ZstdDecompressor().stream_reader(data)
        parts: list[bytes] = []
        size = 0
        while size <= bound:
            more = reader.read(min(step, bound + 1 - size))
            if not more:
                break
            if watch is not None:
                watch(more)
            parts.append(more)
            size += len(more)
        return parts[0] if len(parts) == 1 else b"".join(parts)
    except zstandard.ZstdError as exc:
        raise InflateError(f"zstd chunk does not decompress ({exc})") from None


def _lz4(
    data: bytes | memoryview, bound: int, watch: Callable[[bytes | memoryview], None] | None
) -> bytes:
    import lz4.frame  # type: ignore[import-untyped]

    step = bound + 1 if watch is None else _READ_STEP
    try:
        decoder = lz4.frame.LZ4FrameDecompressor()
        parts: list[bytes] = []
        size = 0
        source = bytes(data)
        while size <= bound:
            more = bytes(decoder.decompress(source, max_length=min(step, bound + 1 - size)))
            source = b""
            if watch is not None and more:
                watch(more)
            parts.append(more)
            size += len(more)
            if decoder.eof or (not more and decoder.needs_input):
                break
        if size <= bound and not decoder.eof:
            raise InflateError("lz4 chunk ends before its frame does")
        return parts[0] if len(parts) == 1 else b"".join(parts)
    except RuntimeError as exc:
        raise InflateError(f"lz4 chunk does not decompress ({exc})") from None
