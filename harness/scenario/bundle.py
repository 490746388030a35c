"""The files an iteration reads, packed so that it can run on a machine that cannot see them.

A scenario names files by the client machine's paths: the scenario file, robot files (URDF,
xacro, SDF, MJCF), a world file, and through them meshes, includes, ``package://`` and
``model://`` folders; a client command names its script. A worker on another machine has
none of them. :func:`collect_bundle` finds them on the client by *loading the world once*
(:func:`harness.scenario.world.build_world`) while a Python audit hook notes every file
opened (every model file the harness reads goes through Python: the safe XML reader,
``read_bytes`` of meshes and assets, xacro), and adds the client command's file arguments
and the ``package.xml`` of every package a file lies in (package search looks for it).

The result is a :class:`Bundle`: a manifest of ``(client path, sha256, size)`` plus the
blobs by sha256. A worker keeps blobs in a :class:`BlobStore` (content-addressed: a file
travels to a worker once, whatever scenario or run names it), :func:`materialise`\\ s a
bundle as a tree that mirrors the client's absolute paths under its own folder (so relative
references between files keep working), and :func:`localise_spec` rewrites every client path
of the :class:`~harness.scenario.results.IterationSpec` (a generic walk over its frozen
dataclasses) into that tree, and its output folder into a folder of the worker's own.
:func:`bundle_env` does the same for the package search variables (``ROS_PACKAGE_PATH``, ...).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import shutil
import sys
import tempfile
import threading
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path, PurePath
from types import MappingProxyType
from typing import Any, TypeVar

from harness.models.files.meshes import mesh_cache_dir
from harness.models.files.resolve import MODEL_PATH_VARIABLES
from harness.scenario.errors import RunnerError
from harness.scenario.results import IterationSpec
from harness.scenario.scenario import Scenario

__all__ = [
    "PATH_VARIABLES",
    "BlobStore",
    "Bundle",
    "BundleFile",
    "bundle_env",
    "collect_bundle",
    "localise_spec",
    "materialise",
    "mirror",
    "rewrite_paths",
    "trace_reads",
]

PATH_VARIABLES: tuple[str, ...] = ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH", *MODEL_PATH_VARIABLES)
"""The variables package and model search reads; a worker gets the client's, mirrored."""

_CODE_SUFFIXES = frozenset({".py", ".pyc", ".pyo", ".so", ".pyd", ".pth", ".pyi", ".typed"})
_SYSTEM = (Path("/proc"), Path("/sys"), Path("/dev"))
_MARKERS = ("package.xml", "model.config")
T = TypeVar("T")


@dataclass(frozen=True)
class BundleFile:
    """One file of a bundle: its absolute path on the client, sha256 and size."""

    path: str
    sha256: str
    size: int


@dataclass(frozen=True)
class Bundle:
    """The files one iteration reads (``files``), folders it needs to exist (``dirs``: a
    client's working folder) and the client's package search variables (``env``: name ->
    value, None when unset)."""

    files: tuple[BundleFile, ...]
    dirs: tuple[str, ...] = ()
    env: tuple[tuple[str, str | None], ...] = ()

    @property
    def digest(self) -> str:
        """sha256 of the manifest: the same files at the same paths give the same digest."""
        h = hashlib.sha256()
        for f in self.files:
            h.update(f"f\0{f.path}\0{f.sha256}\n".encode())
        for d in self.dirs:
            h.update(f"d\0{d}\n".encode())
        return h.hexdigest()

    @property
    def size(self) -> int:
        """Bytes of every file together."""
        return sum(f.size for f in self.files)

    def covers(self, path: Path) -> bool:
        """True when ``path`` is a file or folder of the bundle, or a folder above one."""
        text = str(path)
        inside = text.rstrip("/") + "/"
        return any(f.path == text or f.path.startswith(inside) for f in self.files) or any(
            d == text or d.startswith(inside) for d in self.dirs
        )

    def holds(self, path: Path) -> bool:
        """True when ``path`` is a file or folder of the bundle, or inside such a folder (not
        merely a folder above one: a command argument ``/arm`` is a topic, not ``/``'s tree)."""
        text = str(path)
        return any(f.path == text for f in self.files) or any(
            d == text or text.startswith(d.rstrip("/") + "/") for d in self.dirs
        )


# --- finding the files ----------------------------------------------------------------------

_reads: list[set[str]] = []
_reads_lock = threading.Lock()
_hooked = False


def _audit(event: str, args: tuple[Any, ...]) -> None:
    if event != "open" or not _reads:
        return
    try:
        target = args[0]
        if isinstance(target, int):
            return
        _reads[-1].add(os.path.abspath(os.fsdecode(target)))
    except Exception:  # an audit hook must never raise into the code it watches
        return


@contextmanager
def trace_reads() -> Iterator[set[str]]:
    """Collect the absolute path of every file opened (by Python code, in any thread)
    while the block runs. The audit hook stays installed (Python cannot remove one) but
    does nothing outside such a block."""
    global _hooked
    with _reads_lock:
        if not _hooked:
            sys.addaudithook(_audit)
            _hooked = True
        seen: set[str] = set()
        _reads.append(seen)
        try:
            yield seen
        finally:
            _reads.pop()


def _under(path: Path, roots: Iterable[Path]) -> bool:
    return any(path == root or path.is_relative_to(root) for root in roots)


def _python_install() -> tuple[Path, ...]:
    import harness

    dirs = {Path(sys.prefix), Path(sys.base_prefix), Path(harness.__file__).resolve().parent}
    return tuple(dirs)


def _env_roots() -> list[Path]:
    roots: list[Path] = []
    for var in PATH_VARIABLES:
        roots += [Path(p).resolve() for p in os.environ.get(var, "").split(os.pathsep) if p]
    return roots


def _path_leaves(value: Any) -> Iterator[Path]:
    """Every :class:`~pathlib.Path` inside ``value`` (dataclasses, tuples, lists, mappings)."""
    if isinstance(value, PurePath):
        yield Path(value)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            yield from _path_leaves(getattr(value, f.name))
    elif isinstance(value, (tuple, list, set, frozenset)):
        for item in value:
            yield from _path_leaves(item)
    elif isinstance(value, Mapping):
        for item in value.values():
            yield from _path_leaves(item)


def _keep(path: Path, roots: list[Path], skip: tuple[Path, ...], install: tuple[Path, ...]) -> bool:
    if path.suffix.lower() in _CODE_SUFFIXES or _under(path, _SYSTEM) or _under(path, skip):
        return False
    if not path.is_file():
        return False
    return _under(path, roots) or not _under(path, install)


def _client_files(spec: IterationSpec) -> tuple[list[Path], list[Path]]:
    """The client command's file arguments (relative to its folder, or absolute) and the
    folder it runs in. The program itself (``python``, ``ros2``) must be on the worker."""
    client = spec.client
    if client is None:
        return [], []
    files = []
    for index, arg in enumerate(client.command):
        if index == 0 and "/" not in arg:
            continue
        if index == 0 and Path(arg) == Path(sys.executable):
            continue  # the client's interpreter: the worker runs its own (see localise_spec)
        candidate = Path(arg) if os.path.isabs(arg) else client.cwd / arg
        if candidate.is_file():
            files.append(candidate.absolute())
    return files, [client.cwd.absolute()]


def collect_bundle(spec: IterationSpec) -> tuple[Bundle, dict[str, bytes]]:
    """The bundle of ``spec`` and its blobs (sha256 -> bytes). Loading the world here also
    means a scenario whose robot does not load fails on the client, before anything is sent."""
    from harness.scenario.world import build_world

    scenario = spec.scenario
    leaves = [p.absolute() for p in _path_leaves(scenario)]
    leaves += [p.absolute() for p in _path_leaves(spec.client)]
    roots = [p if p.is_dir() else p.parent for p in leaves] + _env_roots()
    with tempfile.TemporaryDirectory(prefix="harness-bundle-") as tmp:
        with trace_reads() as seen:
            build_world(scenario, Path(tmp))
        skip = (Path(tmp), mesh_cache_dir())
        install = _python_install()
        paths = {p for p in map(Path, seen) if _keep(p, roots, skip, install)}
    paths |= {p for p in leaves if p.is_file() and not _under(p, _python_install())}
    extra, dirs = _client_files(spec)
    paths |= set(extra)
    for path in list(paths):
        for above in path.parents:
            paths |= {above / m for m in _MARKERS if (above / m).is_file()}
    blobs: dict[str, bytes] = {}
    files = []
    for path in sorted(paths):
        data = path.read_bytes()
        digest = hashlib.sha256(data).hexdigest()
        blobs[digest] = data
        files.append(BundleFile(str(path), digest, len(data)))
    dirs += [p for p in leaves if p.is_dir()]
    env = tuple((var, os.environ.get(var)) for var in PATH_VARIABLES)
    bundle = Bundle(tuple(files), tuple(sorted({str(d) for d in dirs})), env)
    return bundle, blobs


# --- on the worker --------------------------------------------------------------------------


class BlobStore:
    """Blobs by sha256 in ``folder`` (written atomically, checked on the way in)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def path(self, digest: str) -> Path:
        """Where blob ``digest`` lives."""
        return self.folder / digest

    def missing(self, digests: Iterable[str]) -> list[str]:
        """The digests not stored yet (each once, in the order given)."""
        out: list[str] = []
        for d in digests:
            if d not in out and not self.path(d).is_file():
                out.append(d)
        return out

    def put(self, digest: str, data: bytes) -> None:
        """Store ``data`` as ``digest``; refuse bytes whose sha256 is another."""
        actual = hashlib.sha256(data).hexdigest()
        if actual != digest:
            raise RunnerError(f"blob {digest[:12]}: received bytes hash to {actual[:12]}")
        self.folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".part")
        with os.fdopen(fd, "wb") as out:
            out.write(data)
        os.replace(tmp, self.path(digest))


def mirror(path: str | Path, root: Path) -> Path:
    """Client path ``path`` inside a tree materialised at ``root``."""
    return root.joinpath(*Path(path).absolute().parts[1:])


def materialise(bundle: Bundle, store: BlobStore, folder: Path) -> Path:
    """The bundle as a tree mirroring the client's paths, ``<folder>/<digest>/`` (built once;
    built aside and renamed into place, so concurrent workers never see half a tree)."""
    root = folder / bundle.digest
    if root.is_dir():
        return root
    folder.mkdir(parents=True, exist_ok=True)
    building = folder / f".{bundle.digest}.{uuid.uuid4().hex}"
    for f in bundle.files:
        target = mirror(f.path, building)
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(store.path(f.sha256), target)
        except OSError:
            shutil.copyfile(store.path(f.sha256), target)
    for d in bundle.dirs:
        mirror(d, building).mkdir(parents=True, exist_ok=True)
    building.mkdir(parents=True, exist_ok=True)
    try:
        os.rename(building, root)
    except OSError:  # another worker finished the same tree first
        shutil.rmtree(building, ignore_errors=True)
    return root


def rewrite_paths(value: T, change: Callable[[Path], Path]) -> T:
    """``value`` with every :class:`~pathlib.Path` inside replaced by ``change(path)``
    (through frozen dataclasses, tuples, lists and mappings; other values unchanged)."""
    return _rewrite(value, change)  # type: ignore[no-any-return]


def _rewrite(value: Any, change: Callable[[Path], Path]) -> Any:
    if isinstance(value, PurePath):
        return change(Path(value))
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        updates = {}
        for f in dataclasses.fields(value):
            if not f.init:
                continue
            old = getattr(value, f.name)
            new = _rewrite(old, change)
            if new is not old:
                updates[f.name] = new
        return dataclasses.replace(value, **updates) if updates else value
    if isinstance(value, (tuple, list)):
        items = [_rewrite(v, change) for v in value]
        if all(a is b for a, b in zip(items, value, strict=True)):
            return value
        return type(value)(items) if isinstance(value, list) else tuple(items)
    if isinstance(value, Mapping):
        changed = {k: _rewrite(v, change) for k, v in value.items()}
        if all(changed[k] is v for k, v in value.items()):
            return value
        return MappingProxyType(changed) if isinstance(value, MappingProxyType) else changed
    return value


def localise_spec(spec: IterationSpec, bundle: Bundle, root: Path, out_dir: Path) -> IterationSpec:
    """``spec`` on the worker: every client path the bundle covers moved into the tree at
    ``root``, its output into ``out_dir`` (the recording keeps its place relative to the
    iteration folder), absolute file arguments of the client command mirrored, the
    client's interpreter replaced by ``python`` (the worker runs its own), and file sinks of
    the ``logging`` section writing into ``<out_dir>/sinks/``."""

    def change(path: Path) -> Path:
        return mirror(path, root) if path.is_absolute() and bundle.covers(path) else path

    recording = _relative_output(spec)
    moved = rewrite_paths(
        dataclasses.replace(spec, out_dir=Path("/"), recording_path=Path("/")), change
    )
    client = moved.client
    if client is not None:
        command = [
            str(mirror(a, root)) if os.path.isabs(a) and bundle.holds(Path(a)) else a
            for a in client.command
        ]
        if command and Path(command[0]) == Path(sys.executable):
            command[0] = "python"
        client = dataclasses.replace(client, command=tuple(command))
    return dataclasses.replace(
        moved,
        scenario=_local_sinks(moved.scenario, out_dir),
        client=client,
        out_dir=out_dir,
        recording_path=out_dir / recording,
    )


def _local_sinks(scenario: Scenario, out_dir: Path) -> Scenario:
    """File sinks of the ``logging`` section write into ``<out_dir>/sinks/`` (so their files
    come back with the iteration's) instead of a client path the worker does not have."""
    logging = scenario.logging
    destinations = []
    for sink in logging.destinations:
        options = tuple(
            (key, str(out_dir / "sinks" / Path(value).name))
            if key == "path" and isinstance(value, str)
            else (key, value)
            for key, value in sink.options
        )
        destinations.append(dataclasses.replace(sink, options=options))
    if tuple(destinations) == logging.destinations:
        return scenario
    moved = dataclasses.replace(logging, destinations=tuple(destinations))
    return dataclasses.replace(scenario, logging=moved)


def _relative_output(spec: IterationSpec) -> Path:
    """The recording's path relative to the iteration folder (its name if it lies elsewhere)."""
    if spec.recording_path.is_relative_to(spec.out_dir):
        return spec.recording_path.relative_to(spec.out_dir)
    return Path(spec.recording_path.name)


def bundle_env(bundle: Bundle, root: Path) -> dict[str, str | None]:
    """The package search variables for the worker: the client's, every folder mirrored."""
    env: dict[str, str | None] = {}
    for var, value in bundle.env:
        if value is None:
            env[var] = None
            continue
        parts = [str(mirror(p, root)) if os.path.isabs(p) else p for p in value.split(os.pathsep)]
        env[var] = os.pathsep.join(parts)
    return env
