"""Specs from MJCF files and strings, compiled into models, with MuJoCo's errors turned into
one-line :class:`~harness.models.errors.CompileError` (and friends) naming the source and
MuJoCo's warnings re-issued as :class:`~harness.models.errors.ModelWarning`.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import mujoco

from harness.models.errors import CompileError, MasslessLinkError, ModelWarning
from harness.models.files.assets import embed_files
from harness.models.files.confine import confinement
from harness.models.files.limits import check_spec
from harness.models.mjcf.files import check_mjcf_files, mjcf_in_memory

__all__ = [
    "compile_lenient",
    "compile_spec",
    "mujoco_message",
    "mujoco_warnings",
    "spec_from_file",
    "spec_from_string",
]


def spec_from_file(path: Path) -> mujoco.MjSpec:
    """The spec of an MJCF file, its includes and assets checked first. In a rebuild from a
    recording (:mod:`harness.models.files.confine`) MuJoCo gets no path: the text with its includes
    inlined (:func:`~harness.models.mjcf.files.mjcf_in_memory`), then every file it references
    as an in-memory asset (:func:`~harness.models.files.assets.embed_files`)."""
    if confinement() is not None:
        spec = spec_from_string(mjcf_in_memory(path), str(path))
        spec.modelfiledir = str(path.parent) + os.sep  # what from_file sets: found by Python
        embed_files(spec, source=str(path))
        return spec
    check_mjcf_files(path)  # before MuJoCo opens its includes and assets
    try:
        with mujoco_warnings():
            return mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise CompileError(f"{path}: {mujoco_message(exc)}") from None


def spec_from_string(
    xml: str, source: str, assets: Mapping[str, bytes] | None = None
) -> mujoco.MjSpec:
    """The spec of MJCF text with in-memory ``assets``; ``source`` names it in errors."""
    try:
        with mujoco_warnings():
            return mujoco.MjSpec.from_string(xml, assets=dict(assets or {}))
    except ValueError as exc:
        raise CompileError(f"{source}: {mujoco_message(exc)}") from None


def mujoco_message(exc: Exception) -> str:
    """A MuJoCo error on one line, without its ``Error:`` headers."""
    return " ".join(str(exc).replace("Error:", "").split())


_MASSLESS = re.compile(r"mass and inertia of moving bodies.*?Element name '([^']*)'", re.S)


def compile_spec(
    spec: mujoco.MjSpec, source: str, *, check: bool = True, strict: bool = False
) -> mujoco.MjModel:
    """Compile ``spec`` (its size limits checked first unless ``check`` is false); a massless
    moving link, a bad inertia or any other compiler error becomes a one-line error naming
    ``source`` (it names strict mode as the cause only when ``strict`` was asked)."""
    if check:
        check_spec(spec, source)  # before the compiler allocates what the model declares
    try:
        with mujoco_warnings():
            return spec.compile()
    except ValueError as exc:
        text = str(exc)
        match = _MASSLESS.search(text)
        if match:
            raise MasslessLinkError(
                f'{source}: <link name="{match.group(1)}">: moving link has no mass or '
                "inertia (fix the <inertial>, or load with repair_inertia=True)"
            ) from None
        triangle = _TRIANGLE.search(text)
        if triangle:
            hint = (
                "load without strict=True to have it repaired"
                if strict
                else "MuJoCo's compiler refuses it; fix the <inertial>"
            )
            raise CompileError(
                f'{source}: <link name="{triangle.group(1)}">: inertia violates the triangle '
                f"inequality (A + B >= C) ({hint})"
            ) from None
        raise CompileError(f"{source}: {mujoco_message(exc)}") from None


_TRIANGLE = re.compile(r"inertia must satisfy A \+ B >= C.*?Element name '([^']*)'", re.S)
_MESH_VOLUME = re.compile(r"mesh volume is too small: (\S+)")


def compile_lenient(
    spec: mujoco.MjSpec, source: str, *, strict: bool, notes: list[str]
) -> mujoco.MjModel:
    """Compile; a mesh too thin for MuJoCo's volume-based inertia gets shell inertia (its
    body's inertia comes from the file's ``<inertial>`` anyway), with a note added to
    ``notes``, unless ``strict``."""
    # the limits once, before the first compile: after a failed compile the spec's tree
    # reports that compile's error when read, whatever was changed since
    check_spec(spec, source)
    for _ in range(64):
        try:
            return compile_spec(spec, source, check=False, strict=strict)
        except CompileError as exc:
            match = _MESH_VOLUME.search(str(exc))
            mesh = None if match is None or strict else spec.mesh(match.group(1))
            if mesh is None or mesh.inertia == mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL:
                raise
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            notes.append(
                f"{source}: mesh {match.group(1) if match else ''} encloses (almost) no volume: "
                "its inertia is computed as a shell"
            )
    return compile_spec(spec, source, check=False, strict=strict)


# An attached MJCF robot's <size> memory hints (nkey: it brings keyframes) lose to the world's:
# harmless, unlike other attach conflicts (an ignored <option timestep>).
_SIZE_HINT_CONFLICT = (
    r"\s*Attach conflict[^\n]*"
    r"(\n(nkey|nuserdata|nuser_\w+|memory|nconmax|njmax|nstack):[^\n]*)+\s*$"
)


@contextmanager
def mujoco_warnings() -> Iterator[None]:
    """Re-issue MuJoCo's warnings (printed or Python) as :class:`ModelWarning`; drop the one
    about attaching with an empty prefix (robot names stay unprefixed on purpose: one robot)
    and attach conflicts about size hints only."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        mujoco.set_mju_user_warning(previous)
    # the printed attach conflict is a headline only: its Python twin has the details
    messages = [m for m in messages if not m.lstrip().startswith("Attach conflict")]
    for warning in caught:
        text = str(warning.message)
        if "empty prefix" in text or re.match(_SIZE_HINT_CONFLICT, text):
            continue
        if text.lstrip().startswith("Attach conflict"):
            messages.append(text)
        else:
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    for message in messages:
        if "empty prefix" not in message:
            warnings.warn(" ".join(message.split()), ModelWarning, stacklevel=4)
