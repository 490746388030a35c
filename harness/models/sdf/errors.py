"""Errors and warnings of the SDFormat reader: each message names the file and the element."""

from __future__ import annotations

from harness.errors import ModelError

__all__ = [
    "SdfCycleError",
    "SdfError",
    "SdfFrameError",
    "SdfIncludeError",
    "SdfInertiaError",
    "SdfStructureError",
    "SdfSyntaxError",
    "SdfVersionError",
    "SdfWarning",
]


class SdfError(ModelError):
    """An SDFormat file cannot be read."""


class SdfVersionError(SdfError):
    """The ``<sdf version>`` is missing or outside 1.4-1.11."""


class SdfSyntaxError(SdfError):
    """A value is malformed (pose, vector, number, boolean) or a required element is missing."""


class SdfStructureError(SdfError):
    """Duplicate names, a joint type or reference that cannot be used, a model without links."""


class SdfFrameError(SdfError):
    """A ``relative_to``, ``attached_to``, ``expressed_in``, parent, child, canonical link or
    placement frame names no frame in its scope."""


class SdfCycleError(SdfError):
    """``attached_to`` or ``relative_to`` references (or includes) form a cycle."""


class SdfIncludeError(SdfError):
    """An ``<include>`` names a model that cannot be found or read."""


class SdfInertiaError(SdfError):
    """An ``<inertial>`` has a non-positive mass or physically impossible moments."""


class SdfWarning(UserWarning):
    """Something in the file has no equivalent in the harness and was left out."""
