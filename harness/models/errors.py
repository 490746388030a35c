"""Errors of :mod:`harness.models`: each names the file and the element it is about."""

from __future__ import annotations

from harness.errors import ModelError

__all__ = [
    "CompileError",
    "MasslessLinkError",
    "MeshError",
    "ModelError",
    "ModelStructureError",
    "ModelWarning",
    "OutsideReferenceError",
    "ResolveError",
    "UnknownPackageError",
    "XMLError",
    "XacroError",
]


class XMLError(ModelError):
    """A model file is not well-formed XML, is unsafe (entity declarations) or unreadable."""


class XacroError(ModelError):
    """A xacro file cannot be expanded: a syntax error, an undefined argument, a failing
    expression or include (the message names the file and the argument or line)."""


class ResolveError(ModelError):
    """A referenced file (mesh, include, model) does not exist."""


class OutsideReferenceError(ResolveError):
    """A model rebuilt from a recording names a file outside the recording's attachments
    (:mod:`harness.models.files.confine`)."""


class UnknownPackageError(ResolveError):
    """A ``package://`` or ``model://`` URI names a package found in no search path."""


class MeshError(ModelError):
    """A mesh has a format MuJoCo cannot decode and that cannot be converted."""


class ModelStructureError(ModelError):
    """The description is inconsistent: missing links, unknown joint types, bad values."""


class MasslessLinkError(ModelError):
    """A moving link has no mass or inertia (``repair_inertia=True`` repairs it)."""


class CompileError(ModelError):
    """MuJoCo refused to compile the model for another reason (its message is kept)."""


class ModelWarning(UserWarning):
    """A warning MuJoCo printed while parsing or compiling a model (re-issued as a Python
    warning instead of being printed)."""
