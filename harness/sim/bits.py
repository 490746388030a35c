"""Bit equality of arrays (:mod:`harness.bits`, re-exported here, where it was first defined)."""

from __future__ import annotations

from harness.bits import differing, same_bits

__all__ = ["differing", "same_bits"]
