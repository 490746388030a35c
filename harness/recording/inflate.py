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
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import zstandard

__all__ = [
    "DEFAULT_CHUNK_BYTES",
    "DEFAULT_FILE_BYTES",
    "InflateError",
    "InflateLimits",
    "current_limits",
    "decompress",
]

DEFAULT_CHUNK_BYTES = 2**30
DEFAULT_FILE_BYTES = 64 * 2**30
_CHUNK_ENV = "HARNESS_MAX_CHUNK_BYTES"
_FILE_ENV = "HARNESS_MAX_FILE_BYTES"
_READ_STEP = 4 * 2**20


class InflateError(ValueError):
    """A chunk does not decompress within the limits (or not at all)."""


@dataclass(frozen=True, slots=True)
class InflateLimits:
    """Most bytes one chunk may decompress to, and all chunks of one file together."""

    chunk_bytes: int = DEFAULT_CHUNK_BYTES
    file_bytes: int = DEFAULT_FILE_BYTES

    def charge_file(self, total: int) -> None:
        """Raise :class:`InflateError` when a file's chunks declare ``total`` bytes, more
        than :attr:`file_bytes`."""
        if total > self.file_bytes:
            raise InflateError(
                f"the file's chunks declare {total} bytes decompressed in all, over the limit "
                f"of {self.file_bytes} ({_FILE_ENV})"
            )


def _env_bytes(name: str, default: int) -> int:
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value <= 0:
        raise InflateError(f"{name}={text!r}: expected a positive number of bytes")
    return value


def current_limits() -> InflateLimits:
    """The limits in force: the defaults, or what the environment variables say."""
    return InflateLimits(
        _env_bytes(_CHUNK_ENV, DEFAULT_CHUNK_BYTES), _env_bytes(_FILE_ENV, DEFAULT_FILE_BYTES)
    )


def decompress(
    compression: str,
    data: bytes | memoryview,
    declared: int,
    limits: InflateLimits | None = None,
) -> bytes:
    """``data`` decompressed, at most ``declared`` bytes (itself at most the chunk limit);
    raises :class:`InflateError` when the claim is over the limit, when the data inflates
    to more than it claims, or when it does not decompress."""
    limit = (limits or current_limits()).chunk_bytes
    if declared > limit:
        raise InflateError(
            f"chunk declares {declared} bytes decompressed, over the limit of {limit} "
            f"({_CHUNK_ENV})"
        )
    if compression == "zstd":
        out = _zstd(data, declared)
    elif compression == "lz4":
        out = _lz4(data, declared)
    elif compression == "":
        out = bytes(data)
    else:
        raise InflateError(f"unsupported chunk compression {compression!r}")
    if len(out) > declared:
        raise InflateError(f"chunk decompresses to more than the {declared} bytes it declares")
    return out


def _zstd(data: bytes | memoryview, bound: int) -> bytes:
    # A stream, not ZstdDecompressor.decompress: that allocates what the frame header claims.
    try:
        reader = zstandard.ZstdDecompressor().stream_reader(data)
        first = reader.read(bound + 1)
        if len(first) > bound or not first:
            return bytes(first)
        parts = [first]
        size = len(first)
        while size <= bound:
            more = reader.read(min(_READ_STEP, bound + 1 - size))
            if not more:
                break
            parts.append(more)
            size += len(more)
        return b"".join(parts)
    except zstandard.ZstdError as exc:
        raise InflateError(f"zstd chunk does not decompress ({exc})") from None


def _lz4(data: bytes | memoryview, bound: int) -> bytes:
    import lz4.frame  # type: ignore[import-untyped]

    try:
        decoder = lz4.frame.LZ4FrameDecompressor()
        out = bytes(decoder.decompress(bytes(data), max_length=bound + 1))
        if len(out) <= bound and not decoder.eof:
            raise InflateError("lz4 chunk ends before its frame does")
        return out
    except RuntimeError as exc:
        raise InflateError(f"lz4 chunk does not decompress ({exc})") from None
