"""CRC-32 as MCAP (and zlib) define it, at the best speed available: ISA-L's when the optional
``isal`` package is installed (about 8x zlib's on this kind of machine; a file's chunk CRCs
are most of the cost of opening it), else zlib's. Both give the same value."""

from __future__ import annotations

import importlib
import zlib
from collections.abc import Callable

__all__ = ["crc32"]


def _pick() -> Callable[[bytes | bytearray | memoryview], int]:
    try:
        module = importlib.import_module("isal.isal_zlib")
    except ImportError:
        return zlib.crc32
    fast: Callable[[bytes | bytearray | memoryview], int] = module.crc32
    return fast


crc32 = _pick()
"""``crc32(data) -> int``."""
