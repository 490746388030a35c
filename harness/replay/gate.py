"""The recording gate: the one way a model is rebuilt from a recording (README "Trust":
recordings are data; nothing in them runs, nothing outside them is read).

Every path that turns a recording into a model goes through this module: ``harness replay``
(every level), ``harness diff``, ``harness replay --actuation`` (re-simulation), base re-runs
and their Python equivalents (:func:`harness.replay.verify`, :func:`~harness.replay.diff`,
:func:`~harness.replay.resimulate`, :func:`harness.replay.pipeline.replay_pipeline`), through
:mod:`harness.replay.source`. ``harness play`` and ``harness inspect`` build no model (play
serves attached mesh bytes, nothing else).

- **Sources** (:func:`recorded_sources`): the ``source/...`` attachments, each name a plain
  relative path (no absolute path, ``..``, backslash or empty part). A xacro source (a
  ``.xacro`` file, or XML declaring the xacro namespace ``http://www.ros.org/wiki/xacro`` or
  using ``xacro:`` names, together with a ``${...}``/``$(...)`` expression or ``<xacro:...>``
  element) is never expanded: xacro's expressions run Python and its ``include``, ``$(env)``
  and ``load_yaml`` read the local machine. The recorder attaches a xacro robot's *expanded*
  URDF as its model (``source/model/<name>.urdf``) and the files the expansion read as
  ``source/xacro/...``; those are left out with a note. A recording whose model source is
  itself xacro carries no expanded description and is refused with one line.
- **Links** (:func:`source_links`): a source whose bytes another ``source/`` attachment
  carries is not attached again but listed in ``source-links.json``
  (:mod:`harness.recording.sourcelinks`); it is laid out from that attachment's bytes, its
  name and its target checked as above, the target one of the recording's ``source/``
  attachments, at most 10,000 links and 1 GiB laid out through them.
- **References** (:func:`rebuild_folder`): the sources are written into a fresh private
  folder and the model is loaded inside :func:`harness.models.files.confine.confined_to` it: every
  file reference (mesh, ``package://``, ``model://``, ``file://``, absolute, ``..``, SDF
  ``<uri>``/``<include>``, MJCF ``file``/``meshdir``/``texturedir``/``<include>``) must lie
  inside it, decided on the reference's text before any file is looked at, or the rebuild is
  refused with one line naming the reference (:class:`UnsafeRecordingError`), the same line
  whether that path exists on this machine or not. Package and model searches see only the
  folder. MuJoCo is given no path: URDF and SDF meshes reach it as in-memory assets (its
  virtual file system); an MJCF source is read in Python, its ``<include>`` files inlined,
  and parsed from the string, every file it references then embedded as an asset
  (:func:`harness.models.build.compiler.spec_from_file` while confined).
- **Binary model** (:func:`model_from_mjb`): ``model.mjb`` is first loaded in a child process
  with limits on memory and CPU time (:data:`MJB_CPU_SECONDS`, :func:`mjb_memory_limit`):
  MuJoCo's binary reader allocates what the file's header declares before the model limits
  can look at it, and a malformed file could crash it; only bytes the child loaded are loaded
  here, from memory (MuJoCo's virtual file system), then checked against the model limits.
  (Rebuilding from the MJCF text instead would lose bit-exactness: MuJoCo writes it with 6
  significant digits.)
- **MJCF text** (:func:`model_from_mjcf_text`): ``model.mjcf.xml`` compiled from memory
  with every reference confined to its folder, the limits checked before compiling.

Nothing in a recording is unpickled or evaluated: metadata is JSON (``json.loads``), records
are CDR decoded against declared message definitions.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import posixpath
import re
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import NamedTuple

import mujoco

from harness.errors import HarnessError
from harness.models.build.compiler import spec_from_file
from harness.models.errors import CompileError, OutsideReferenceError, XacroError
from harness.models.files.confine import confined_to
from harness.models.files.limits import check_model_limits, check_spec
from harness.recording import Recording, RecordingDamagedError
from harness.recording.layout import (
    ATTACHMENT_MODEL,
    ATTACHMENT_MODEL_BINARY,
    ATTACHMENT_SOURCE_PREFIX,
)
from harness.recording.sourcelinks import (
    ATTACHMENT_SOURCE_LINKS,
    MAX_LINKED_BYTES,
    parse_source_links,
)
from harness.replay.errors import (
    ModelAttachmentError,
    SourceLeftOutWarning,
    UnsafeRecordingError,
)

__all__ = [
    "MJB_CPU_SECONDS",
    "RecordedSources",
    "is_xacro_source",
    "mjb_memory_limit",
    "model_from_mjb",
    "model_from_mjcf_text",
    "rebuild_folder",
    "recorded_sources",
    "refused",
    "source_links",
    "source_name",
    "warn_left_out",
]

XACRO_NAMESPACE = b"http://www.ros.org/wiki/xacro"
_XACRO_USE = re.compile(rb"<\s*xacro:|\$\{|\$\(")
_XACRO_NAME = re.compile(rb"<\s*/?\s*xacro:|xmlns:xacro", re.I)
_COMMENT = re.compile(rb"<!--.*?-->", re.S)  # as harness.models.xacro.expand.is_xacro strips them
_XML_SUFFIXES = (".urdf", ".xml", ".sdf", ".world", ".mjcf", ".srdf", ".xacro", ".launch")

MJB_CPU_SECONDS = 60
"""CPU seconds the child loading ``model.mjb`` may use."""


def mjb_memory_limit(size: int) -> int:
    """Address space the child loading a ``model.mjb`` of ``size`` bytes may use: 2 GiB for
    the interpreter and MuJoCo, plus eight times the file (a model in memory is about its file
    size; meshes are stored decoded in both)."""
    return 2 * 1024**3 + 8 * size


class RecordedSources(NamedTuple):
    """The source attachments a model may be rebuilt from (name under ``source/`` -> bytes)
    and the notes on what was left out (xacro sources)."""

    files: dict[str, bytes]
    notes: tuple[tuple[str, str], ...]
    """(name under ``source/``, note) of each source left out."""


def is_xacro_source(name: str, blob: bytes) -> bool:
    """Whether the attachment ``name`` is a xacro source: a ``.xacro`` file, or a file whose
    text names the xacro namespace (or a ``xacro:`` element) and uses xacro (an element or a
    ``${...}``/``$(...)`` expression outside comments). A wider test than the loader's
    (:func:`harness.models.xacro.expand.is_xacro`: the whole file, any spelling of the namespace),
    so what the loader would expand is always caught here; a URDF xacro wrote (which may keep
    the namespace declaration) is not xacro. (While a rebuild is confined, the loader refuses
    to expand xacro too: :func:`harness.models.urdf.source.read_urdf_source`.)"""
    if name.lower().endswith(".xacro"):
        return True
    named = XACRO_NAMESPACE in blob or _XACRO_NAME.search(blob) is not None
    return named and _XACRO_USE.search(_COMMENT.sub(b"", blob)) is not None


def source_name(name: str) -> str | None:
    """``name`` (an attachment name under ``source/``) when it is a plain relative path that
    stays inside its folder, else None."""
    if not name or "\\" in name or "\0" in name or name.startswith("/"):
        return None
    parts = name.split("/")
    if any(part in ("", ".", "..") for part in parts) or posixpath.normpath(name) != name:
        return None
    return name


def refused(rec: Recording, reason: str) -> UnsafeRecordingError:
    """The one-line refusal of ``rec`` for ``reason``."""
    return UnsafeRecordingError(f"{rec.path}: {' '.join(reason.split())}")


def recorded_sources(rec: Recording) -> RecordedSources:
    """The ``source/...`` attachments of ``rec`` a model may be rebuilt from: every name
    checked (:func:`source_name`), the names linked to another attachment's bytes laid out
    (:func:`source_links`), xacro sources (:func:`is_xacro_source`) left out with a note. A
    damaged attachment is a :class:`ModelAttachmentError`; an unsafe name an
    :class:`UnsafeRecordingError`."""
    raw: dict[str, bytes] = {}
    for full in rec.attachment_names:
        if not full.startswith(ATTACHMENT_SOURCE_PREFIX):
            continue
        name = full.removeprefix(ATTACHMENT_SOURCE_PREFIX)
        if source_name(name) is None:
            raise refused(rec, f"source attachment {full!r} is not a plain relative name")
        try:
            raw[name] = rec.attachment(full)
        except RecordingDamagedError as exc:
            raise ModelAttachmentError(str(exc)) from None
    links = source_links(rec, {name: len(blob) for name, blob in raw.items()})
    raw.update({name: raw[target] for name, target in links.items()})
    files: dict[str, bytes] = {}
    notes: list[tuple[str, str]] = []
    for name, blob in raw.items():
        if is_xacro_source(name, blob):
            notes.append(
                (
                    name,
                    f"{full_name(name)}: a xacro source, left out (never expanded from a "
                    "recording)",
                )
            )
            continue
        files[name] = blob
    return RecordedSources(files, tuple(notes))


def full_name(name: str) -> str:
    """The attachment name of the source ``name``."""
    return ATTACHMENT_SOURCE_PREFIX + name


def source_links(rec: Recording, attached: Mapping[str, int]) -> dict[str, str]:
    """The checked links of ``rec`` (:mod:`harness.recording.sourcelinks`): name under
    ``source/`` -> the name under ``source/`` whose attachment carries its bytes. Refused
    with one line (:class:`UnsafeRecordingError`) when a name is not a plain relative path,
    a target is not a ``source/`` attachment, a name is also attached, or the links lay out
    more than :data:`~harness.recording.sourcelinks.MAX_LINKED_BYTES`. ``attached``: the
    size of each ``source/`` attachment by its name under ``source/``."""
    if ATTACHMENT_SOURCE_LINKS not in rec.attachment_names:
        return {}
    try:
        blob = rec.attachment(ATTACHMENT_SOURCE_LINKS)
    except RecordingDamagedError as exc:
        raise ModelAttachmentError(str(exc)) from None
    try:
        links = parse_source_links(blob)
    except ValueError as exc:
        raise refused(rec, f"attachment {ATTACHMENT_SOURCE_LINKS!r}: {exc}") from None
    total = 0
    for name, target in links.items():
        for part in (name, target):
            if source_name(part) is None:
                raise refused(
                    rec,
                    f"{ATTACHMENT_SOURCE_LINKS}: source name {part!r} is not a plain relative name",
                )
        if target not in attached:
            raise refused(
                rec,
                f"{ATTACHMENT_SOURCE_LINKS}: {name!r} names {full_name(target)!r}, which is not "
                "attached",
            )
        if name in attached:
            raise refused(rec, f"{ATTACHMENT_SOURCE_LINKS}: {full_name(name)!r} is also attached")
        total += attached[target]
        if total > MAX_LINKED_BYTES:
            raise refused(
                rec,
                f"{ATTACHMENT_SOURCE_LINKS}: its links lay out more than the limit of "
                f"{MAX_LINKED_BYTES} bytes",
            )
    return links


def warn_left_out(rec: Recording, sources: RecordedSources) -> None:
    """Say what :func:`recorded_sources` left out, as a
    :class:`~harness.replay.errors.SourceLeftOutWarning` each; the files a xacro robot's
    expansion read, recorded under ``source/xacro/`` beside its expanded URDF, go without
    saying."""
    for name, note in sources.notes:
        if not name.startswith("xacro/"):
            warnings.warn(f"{rec.path}: {note}", SourceLeftOutWarning, stacklevel=3)


def check_model_source(rec: Recording, sources: RecordedSources, name: str) -> None:
    """Refuse with one line when the model source ``name`` (under ``source/``) was left out
    as xacro."""
    full = full_name(name)
    if name not in sources.files and any(left == name for left, _ in sources.notes):
        raise refused(
            rec,
            f"its model source {full!r} is xacro, which is never expanded from a recording, "
            "and the recording carries no expanded description (new recordings attach the "
            "expanded URDF as the model source); replay it from its model.mjb, or record it "
            "again",
        )


def _scrub(text: str, root: Path, real: Path) -> str:
    """``text`` with the rebuild folder named as the attachments it holds (``source/...``)."""
    for folder in sorted({str(root), str(real)}, key=len, reverse=True):
        text = text.replace(folder + os.sep, ATTACHMENT_SOURCE_PREFIX).replace(
            folder, ATTACHMENT_SOURCE_PREFIX.rstrip("/")
        )
    return " ".join(text.split())


@contextlib.contextmanager
def rebuild_folder(rec: Recording, files: Mapping[str, bytes]) -> Iterator[Path]:
    """A fresh private folder holding ``files`` (checked names, see
    :func:`recorded_sources`), model loading confined to it while the block runs (see the
    module docstring). A :class:`~harness.errors.HarnessError` leaving the block names the
    folder as ``source/``; a reference outside it becomes an :class:`UnsafeRecordingError`,
    an attempt to expand xacro too."""
    with tempfile.TemporaryDirectory(prefix="harness-replay-") as tmp:
        root = Path(tmp)
        for name, blob in files.items():
            if source_name(name) is None:
                raise refused(rec, f"source attachment {name!r} is not a plain relative name")
            target = root.joinpath(*name.split("/"))
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW
                with os.fdopen(os.open(target, flags, 0o600), "wb") as out:
                    out.write(blob)
            except OSError as exc:  # a name that is also a folder, too long, a full disk
                raise ModelAttachmentError(
                    f"{rec.path}: source attachment {name!r} cannot be written for the "
                    f"rebuild: {exc.strerror}"
                ) from None
        with confined_to(root) as real:
            try:
                yield real
            except (OutsideReferenceError, XacroError) as exc:
                raise refused(rec, _scrub(str(exc), root, real)) from None
            except HarnessError as exc:
                try:
                    scrubbed = type(exc)(_scrub(str(exc), root, real))
                except TypeError:  # an error class with other arguments: kept as it is
                    raise exc from None
                raise scrubbed from None


_PREFLIGHT = """
import resource, sys

def limit(kind, value):  # never above a limit this process was given
    hard = resource.getrlimit(kind)[1]
    value = value if hard == resource.RLIM_INFINITY else min(value, hard)
    resource.setrlimit(kind, (value, value))

limit(resource.RLIMIT_CPU, int(sys.argv[2]))
limit(resource.RLIMIT_CORE, 0)
import mujoco
blob = sys.stdin.buffer.read()
limit(resource.RLIMIT_AS, int(sys.argv[1]))
mujoco.MjModel.from_binary_path("model.mjb", {"model.mjb": blob})
"""

_PREFLIGHTED: set[str] = set()
"""SHA-256 digests of the binary models this process's children loaded within limits."""


def _preflight(blob: bytes) -> None:
    """Load ``blob`` as an MJB in a child process under memory and CPU limits; raise
    :class:`ValueError` with the reason when it does not load there."""
    digest = hashlib.sha256(blob).hexdigest()
    if digest in _PREFLIGHTED:
        return
    memory = mjb_memory_limit(len(blob))
    try:
        done = subprocess.run(
            [sys.executable, "-I", "-c", _PREFLIGHT, str(memory), str(MJB_CPU_SECONDS)],
            input=blob,
            capture_output=True,
            timeout=4 * MJB_CPU_SECONDS,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise ValueError(f"not loaded within {4 * MJB_CPU_SECONDS} s") from None
    if done.returncode != 0:
        lines = done.stderr.decode("utf-8", "replace").strip().splitlines()
        last = lines[-1][:300] if lines else f"exit status {done.returncode}"
        raise ValueError(
            f"MuJoCo does not load it within {memory // 1024**2} MiB and {MJB_CPU_SECONDS} s "
            f"of CPU ({last})"
        )
    _PREFLIGHTED.add(digest)


def model_from_mjb(blob: bytes) -> mujoco.MjModel:
    """``model.mjb`` from memory, after a child process loaded it within limits; the model
    limits checked before any ``MjData`` allocates what it declares. Raises
    :class:`ValueError` when it does not load, :class:`~harness.models.files.limits.ModelLimitError`
    when it is too large."""
    _preflight(blob)
    model = mujoco.MjModel.from_binary_path(
        ATTACHMENT_MODEL_BINARY, {ATTACHMENT_MODEL_BINARY: blob}
    )
    check_model_limits(model, ATTACHMENT_MODEL_BINARY)
    return model


def model_from_mjcf_text(rec: Recording, text: bytes) -> mujoco.MjModel:
    """``model.mjcf.xml`` compiled with every reference confined to its own (otherwise
    empty) folder, from memory (MuJoCo gets the text, no path), the model limits checked
    before compiling. Raises :class:`ValueError` when MuJoCo refuses the text."""
    with rebuild_folder(rec, {ATTACHMENT_MODEL: text}) as root:
        path = root / ATTACHMENT_MODEL
        try:
            spec = spec_from_file(path)
        except CompileError as exc:
            raise ValueError(str(exc).removeprefix(f"{path}: ")) from None
        check_spec(spec, ATTACHMENT_MODEL)
        return spec.compile()
