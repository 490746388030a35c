"""What a golden recording carries of its robot, and how a golden that refers to its project's
files is checked.

A golden is this test's recording (a snapshot) written with :func:`write_golden`:

- without ``model.mjb`` when the recorded sources rebuild (through the recording gate,
  :func:`harness.replay.source.rebuild_run`) to the model the run simulated (the same MJCF
  SHA-256): replay and diff of the golden rebuild it from the sources; with it otherwise;
- with ``--harness-golden-sources=project`` (ini ``harness_golden_sources = project``), every
  source the project tree holds byte for byte (meshes; a URDF/SDF/MJCF model file the test
  loaded as it is) is not carried but named in :data:`ATTACHMENT_SOURCE_REFS` by its path
  under the rootdir and its SHA-256; a xacro robot's expansion inputs (``source/xacro/...``,
  never used by a rebuild) are left out. Its expanded URDF stays attached.

Such a golden is resolved only here, inside the pytest golden check (:func:`resolved_golden`):
each referenced file is read from the project tree (a plain relative path, inside the rootdir
after symlinks, a regular file), its SHA-256 compared with the recorded one (a changed file
fails the check with one line naming it and the update command), never a xacro file; the
golden is then laid out with those attachments in a temporary file that goes through the
recording gate like any recording. Anywhere else (``harness replay``, ``diff``, ``play``,
``inspect``) a file with :data:`ATTACHMENT_SOURCE_REFS` is refused with one line
(:func:`harness.replay.source.open_recording`, :func:`harness.recording.inspect.inspect`).

Like the other plugin modules, this one imports only the standard library and pytest at import
time.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path

__all__ = [
    "ATTACHMENT_SOURCE_REFS",
    "MAX_PROJECT_FILES",
    "GoldenSourcesChanged",
    "resolved_golden",
    "write_golden",
]

ATTACHMENT_SOURCE_REFS = "source-refs.json"
"""Same as :data:`harness.recording.sourcelinks.ATTACHMENT_SOURCE_REFS` (kept here so that
the plugin imports nothing of the recording package at import time)."""

MAX_PROJECT_FILES = 200_000
"""Files of the project tree looked at when a golden refers to them (the first, in name
order: a larger tree has its remaining files carried)."""

_SKIPPED = {".git", ".hg", ".svn", ".venv", "venv", "node_modules", "__pycache__", ".tox"}


class GoldenSourcesChanged(Exception):
    """A golden's referenced project file changed or cannot be read (one line)."""


def _project_files(rootdir: Path, sizes: set[int], skip: tuple[Path, ...]) -> Iterator[Path]:
    """The regular files under ``rootdir`` (in name order, symlinks not followed, version
    control, virtualenv and ``skip`` folders left out) whose size is in ``sizes``."""
    seen = 0
    for folder, dirs, files in os.walk(rootdir):
        here = Path(folder)
        dirs[:] = sorted(
            d for d in dirs if d not in _SKIPPED and not any(here / d == s for s in skip)
        )
        for name in sorted(files):
            seen += 1
            if seen > MAX_PROJECT_FILES:
                return
            path = here / name
            with contextlib.suppress(OSError):
                st = path.lstat()
                if st.st_size in sizes and path.is_file() and not path.is_symlink():
                    yield path


def _references(
    sources: Mapping[str, bytes], rootdir: Path, skip: tuple[Path, ...]
) -> dict[str, dict[str, str]]:
    """name under ``source/`` -> ``{"path", "sha256"}`` of each of ``sources`` the project
    tree holds byte for byte: the file whose path ends like the name (``package/<pkg>/...``
    as ``<pkg>/...``) when there is one, else the first in name order."""
    digests = {name: hashlib.sha256(blob).hexdigest() for name, blob in sources.items()}
    sizes = {len(blob) for blob in sources.values()}
    candidates: dict[str, list[str]] = {}
    for path in _project_files(rootdir, sizes, skip):
        try:
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError:
            continue
        candidates.setdefault(digest, []).append(path.relative_to(rootdir).as_posix())
    found: dict[str, dict[str, str]] = {}
    for name, digest in digests.items():
        paths = candidates.get(digest)
        if paths:
            tail = "/" + name.removeprefix("package/")
            best = next((p for p in paths if ("/" + p).endswith(tail)), paths[0])
            found[name] = {"path": best, "sha256": digest}
    return found


def write_golden(
    recording: Path, target: Path, *, sources: str, rootdir: Path, skip: tuple[Path, ...] = ()
) -> None:
    """Write ``recording`` as the golden ``target`` (see the module docstring), through a
    temporary file in the same folder and a rename. ``sources``: ``"carry"`` or
    ``"project"`` (refer to the files of ``rootdir``, leaving ``skip`` folders out)."""
    from harness.errors import HarnessError
    from harness.recording import ATTACHMENT_MODEL_BINARY, ATTACHMENT_SOURCE_PREFIX
    from harness.replay import open_recording, rebuild_run

    drop: set[str] = set()
    add: dict[str, bytes] = {}
    with open_recording(recording) as rec:
        names = rec.attachment_names
        if ATTACHMENT_MODEL_BINARY in names:
            try:
                rebuilt = rebuild_run(rec).sha256 == rec.metadata.get("model_sha256")
            except (HarnessError, ValueError):
                rebuilt = False
            if rebuilt:
                drop.add(ATTACHMENT_MODEL_BINARY)
        if sources == "project":
            carried = {
                n.removeprefix(ATTACHMENT_SOURCE_PREFIX): rec.attachment(n)
                for n in names
                if n.startswith(ATTACHMENT_SOURCE_PREFIX)
            }
            xacro = {n for n in carried if n.startswith("xacro/")}
            refs = _references(
                {n: b for n, b in carried.items() if n not in xacro}, rootdir.resolve(), skip
            )
            drop |= {ATTACHMENT_SOURCE_PREFIX + n for n in (*xacro, *refs)}
            if refs:
                add[ATTACHMENT_SOURCE_REFS] = json.dumps(refs, sort_keys=True, indent=0).encode()
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        from harness.recording import copy_recording

        copy_recording(recording, Path(tmp), drop=drop, add=add)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a golden is a project file
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _read_reference(golden: Path, rootdir: Path, name: str, ref: object) -> bytes:
    """The bytes of the project file ``ref`` names, checked (see the module docstring)."""
    from harness.replay import is_xacro_source, source_name

    where = f"{golden}: {ATTACHMENT_SOURCE_REFS}"
    if not isinstance(ref, dict) or not all(
        isinstance(ref.get(k), str) for k in ("path", "sha256")
    ):
        raise GoldenSourcesChanged(f"{where}: entry {name!r} is not {{path, sha256}}")
    rel, digest = str(ref["path"]), str(ref["sha256"])
    if source_name(name) is None or source_name(rel) is None:
        raise GoldenSourcesChanged(f"{where}: {name!r} -> {rel!r} is not a plain relative name")
    path = rootdir / rel
    try:
        real = path.resolve(strict=True)
        if not real.is_relative_to(rootdir.resolve()) or not real.is_file():
            raise GoldenSourcesChanged(f"{where}: {rel!r} is not a file inside {rootdir}")
        blob = real.read_bytes()
    except OSError as exc:
        raise GoldenSourcesChanged(
            f"{golden}: its source {rel} cannot be read ({exc.strerror or exc})"
        ) from None
    if hashlib.sha256(blob).hexdigest() != digest:
        raise GoldenSourcesChanged(
            f"{golden}: its source {rel} changed since the golden was written "
            f"(SHA-256 {hashlib.sha256(blob).hexdigest()[:12]}..., the golden's {digest[:12]}...)"
        )
    if is_xacro_source(name, blob) or is_xacro_source(rel, blob):
        raise GoldenSourcesChanged(f"{where}: {rel!r} is xacro, never read for a golden")
    return blob


@contextlib.contextmanager
def resolved_golden(golden: Path, rootdir: Path) -> Iterator[Path]:
    """``golden`` itself, or, when it refers to project files (:data:`ATTACHMENT_SOURCE_REFS`),
    a temporary copy carrying them (checked by path and SHA-256 under ``rootdir``; raises
    :class:`GoldenSourcesChanged` with one line otherwise)."""
    from harness.errors import RecordingError
    from harness.recording import ATTACHMENT_SOURCE_PREFIX, Recording

    try:
        with Recording(golden) as rec:
            blob = (
                rec.attachment(ATTACHMENT_SOURCE_REFS)
                if ATTACHMENT_SOURCE_REFS in rec.attachment_names
                else None
            )
    except RecordingError:
        blob = None  # a golden that does not read: the diff says why, as for any golden
    try:
        refs = None if blob is None else json.loads(blob.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise GoldenSourcesChanged(
            f"{golden}: {ATTACHMENT_SOURCE_REFS}: {' '.join(str(exc).split())}"
        ) from None
    if refs is None:
        yield golden
        return
    if not isinstance(refs, dict):
        raise GoldenSourcesChanged(f"{golden}: {ATTACHMENT_SOURCE_REFS} is not a JSON object")
    add = {
        ATTACHMENT_SOURCE_PREFIX + str(name): _read_reference(golden, rootdir, str(name), ref)
        for name, ref in sorted(refs.items())
    }
    with tempfile.TemporaryDirectory(prefix="harness-golden-") as tmp:
        full = Path(tmp) / golden.name
        from harness.recording import copy_recording

        copy_recording(golden, full, drop={ATTACHMENT_SOURCE_REFS}, add=add)
        yield full
