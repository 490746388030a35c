"""Iterations on a Dask distributed cluster whose workers share no disk with the client.

:class:`DaskBackend` runs on the client (``harness run --backend dask --scheduler ADDRESS``):

1. per iteration, :func:`harness.scenario.bundle.collect_bundle` lists the files it reads
   (scenario, robot, world, meshes, includes, the client's script); every distinct file is
   scattered to the cluster once, under the key ``harness-blob-<sha256>``;
2. each task (:func:`run_on_worker`) fetches only the blobs its worker's
   :class:`~harness.scenario.bundle.BlobStore` lacks (so a file travels to a worker at most
   once, and never again while the worker's cache folder lives), materialises the bundle as a
   tree mirroring the client's paths, rewrites the spec's paths into it, runs the iteration
   in a folder of its own and sends back every file the iteration wrote (recording, client
   log, generated scene) with the result;
3. the client writes those files into the iteration's folder under ``--out``, puts the
   client's paths back into the result, and keeps a :class:`TransferLog` (what was sent and
   returned, per worker) that ``harness run`` prints under its summary.

Workers: ``dask worker ADDRESS --nthreads 1`` (one iteration at a time per worker process:
an iteration sets the package search variables of its process while it runs, so iterations
in one process are serialised anyway). A worker's cache folder is ``$HARNESS_WORKER_DIR``,
else ``<temp>/harness-worker-<uid>``. The worker needs the harness (same version) and the
client's programs (``python``, ``ros2``), not its files.

The worker trusts nothing it finds on its own disk: the cache folder is created private
(mode 0700) and refused when it is a symbolic link, is owned by another user or grants any
permission to group or others (another local user could otherwise plant files in it, the
predictable name in a shared temporary folder being theirs to take first); every blob is
hashed before use and every tree checked against the bundle's hashes, and what does not match
is fetched or built again.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import os
import shutil
import stat
import tempfile
import threading
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.recording import TailFile
from harness.scenario import interrupt
from harness.scenario.bundle import (
    BlobStore,
    Bundle,
    bundle_env,
    collect_bundle,
    localise_spec,
    materialise,
    mirror,
    rewrite_paths,
)
from harness.scenario.errors import RunnerError
from harness.scenario.results import IterationResult, IterationRunner, IterationSpec
from harness.scenario.runner import OnResult, run_one
from harness.scenario.runner import _failed as failed_result

__all__ = [
    "BLOB_KEY_PREFIX",
    "Artifact",
    "DaskBackend",
    "RemoteOutcome",
    "TransferLog",
    "run_on_worker",
    "unverified_blobs",
    "verified_tree",
    "worker_dir",
]

BLOB_KEY_PREFIX = "harness-blob-"
"""Dask key of a scattered file: the prefix, then the sha256 of its bytes."""

_ITERATION = threading.Lock()  # one iteration per worker process at a time (it sets os.environ)
_FETCH = threading.Lock()


def worker_dir() -> Path:
    """A worker's cache folder: ``$HARNESS_WORKER_DIR``, else ``<temp>/harness-worker-<uid>``,
    created private (mode 0700) when absent.

    Raises :class:`RunnerError` (one line naming the folder) when it exists but is not a
    folder of this process's user that only that user can read, write and enter.
    """
    explicit = os.environ.get("HARNESS_WORKER_DIR")
    folder = (
        Path(explicit)
        if explicit
        else Path(tempfile.gettempdir()) / f"harness-worker-{os.getuid()}"
    )
    folder.parent.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(FileExistsError):
        folder.mkdir(mode=0o700)
    _check_private(folder)
    return folder


def _check_private(folder: Path) -> None:
    """Refuse ``folder`` unless it is a real folder owned by this user with mode ``0?00``."""
    try:
        info = folder.lstat()  # a symbolic link is judged itself, never followed
    except OSError as exc:
        raise RunnerError(f"worker cache {folder}: {exc.strerror}") from None
    fix = "remove it or set HARNESS_WORKER_DIR to a folder of your own"
    if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
        raise RunnerError(
            f"worker cache {folder} is not a folder (a symbolic link or a file): refused; {fix}"
        )
    if info.st_uid != os.geteuid():
        raise RunnerError(
            f"worker cache {folder} is owned by uid {info.st_uid}, not by this worker's user "
            f"(uid {os.geteuid()}): refused; {fix}"
        )
    if info.st_mode & 0o077:
        raise RunnerError(
            f"worker cache {folder} has mode {stat.S_IMODE(info.st_mode):04o}, group or others "
            f"may use it: refused (it must be 0700; chmod 700 it after checking its content, "
            f"or {fix})"
        )


def _sha256_file(path: Path) -> str | None:
    """sha256 of the regular file at ``path`` (not through a symbolic link), None if none."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    h = hashlib.sha256()
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            return None
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def unverified_blobs(store: BlobStore, digests: Sequence[str]) -> list[str]:
    """The digests whose blob is absent from ``store`` or whose stored bytes hash to anything
    else (each once, in the order given): what must be fetched before the blobs are used."""
    out: list[str] = []
    for d in digests:
        if d not in out and _sha256_file(store.path(d)) != d:
            out.append(d)
    return out


def _tree_matches(bundle: Bundle, root: Path) -> bool:
    """True when the tree at ``root`` holds exactly the bundle's files with their hashes (and
    nothing else but its folders)."""
    expected = {mirror(f.path, root): f.sha256 for f in bundle.files}
    for dirpath, dirnames, filenames in os.walk(root):
        here = Path(dirpath)
        for name in dirnames:
            if (here / name).is_symlink():
                return False
        for name in filenames:
            if (here / name) not in expected:
                return False
    return all(_sha256_file(path) == digest for path, digest in expected.items())


def verified_tree(bundle: Bundle, store: BlobStore, folder: Path) -> Path:
    """:func:`~harness.scenario.bundle.materialise` ``bundle`` from ``store`` (its blobs
    verified already) into ``folder``; a tree found there that does not match the bundle's
    hashes is removed and built again."""
    root = folder / bundle.digest
    if root.is_symlink() or (root.exists() and not root.is_dir()):
        root.unlink()
    elif root.is_dir() and not _tree_matches(bundle, root):
        shutil.rmtree(root)
    tree = materialise(bundle, store, folder)
    if not _tree_matches(bundle, tree):  # another process changed it between build and check
        raise RunnerError(f"worker cache tree {tree} does not match its bundle after building it")
    return tree


@dataclass(frozen=True)
class Artifact:
    """A file an iteration wrote: its path relative to the iteration's folder, and bytes."""

    path: str
    data: bytes


@dataclass(frozen=True)
class RemoteOutcome:
    """What a worker sends back: the result (paths still the worker's), the files written
    (``recording`` names the recording among them), and what the worker had to fetch."""

    result: IterationResult
    artifacts: tuple[Artifact, ...]
    recording: str
    out_dir: str
    tree: str
    worker: str
    fetched: int
    fetched_bytes: int


def _fetch(dataset: str, digests: Sequence[str]) -> list[bytes]:
    """The blobs ``digests`` of the run's published dataset, through this worker's client."""
    distributed: Any = importlib.import_module("distributed")
    client = distributed.get_client()
    held: dict[str, Any] = client.get_dataset(dataset)
    data: list[bytes] = client.gather([held[d] for d in digests])
    return data


def _worker_address() -> str:
    try:
        distributed: Any = importlib.import_module("distributed")
        return str(distributed.get_worker().address)
    except (ImportError, ValueError):
        return "local"


def _collect(folder: Path) -> tuple[Artifact, ...]:
    return tuple(
        Artifact(p.relative_to(folder).as_posix(), p.read_bytes())
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    )


def run_on_worker(
    runner: IterationRunner, spec: IterationSpec, bundle: Bundle, dataset: str
) -> RemoteOutcome:
    """On a worker: fetch what the cache lacks, materialise the bundle, run ``spec`` with its
    paths rewritten, and return the result with every file the iteration wrote."""
    base = worker_dir()
    store = BlobStore(base / "blobs")
    with _FETCH:
        missing = unverified_blobs(store, [f.sha256 for f in bundle.files])
        fetched_bytes = 0
        if missing:
            for digest, data in zip(missing, _fetch(dataset, missing), strict=True):
                store.put(digest, data)  # checks the bytes against the digest
                fetched_bytes += len(data)
        tree = verified_tree(bundle, store, base / "trees")
    run_dir = base / "runs" / uuid.uuid4().hex
    local = localise_spec(spec, bundle, tree, run_dir / "out")
    try:
        with _ITERATION:
            saved = {var: os.environ.get(var) for var, _ in bundle.env}
            try:
                _set_env(bundle_env(bundle, tree))
                result = run_one(runner, local)
            finally:
                _set_env(saved)
        artifacts = _collect(local.out_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)
    return RemoteOutcome(
        result=result,
        artifacts=artifacts,
        recording=local.recording_path.relative_to(local.out_dir).as_posix(),
        out_dir=str(local.out_dir),
        tree=str(tree),
        worker=_worker_address(),
        fetched=len(missing),
        fetched_bytes=fetched_bytes,
    )


def _set_env(values: dict[str, str | None]) -> None:
    for var, value in values.items():
        if value is None:
            os.environ.pop(var, None)
        else:
            os.environ[var] = value


def receive(outcome: RemoteOutcome, spec: IterationSpec) -> IterationResult:
    """On the client: write the returned files into ``spec``'s folder and give the result
    the client's paths (worker output folder -> ``spec.out_dir``, tree -> the client's)."""
    spec.out_dir.mkdir(parents=True, exist_ok=True)
    for artifact in outcome.artifacts:
        target = _client_path(spec, outcome.recording, artifact.path)
        target.parent.mkdir(parents=True, exist_ok=True)
        if artifact.path == outcome.recording:
            # One writer per recording path, as for a session recording in this process:
            # a run writing the same --out is refused before the file changes.
            tail = TailFile(target)
            try:
                tail.write(artifact.data)
            finally:
                tail.close()
        else:
            target.write_bytes(artifact.data)
    out_dir = Path(outcome.out_dir)
    tree = Path(outcome.tree)

    def change(path: Path) -> Path:
        if path.is_relative_to(out_dir):
            return _client_path(spec, outcome.recording, path.relative_to(out_dir).as_posix())
        if path.is_relative_to(tree):
            return Path("/", path.relative_to(tree))
        return path

    return rewrite_paths(outcome.result, change)


def _client_path(spec: IterationSpec, recording: str, relative: str) -> Path:
    return spec.recording_path if relative == recording else spec.out_dir / relative


@dataclass
class TransferLog:
    """What crossed the network in a run: files sent (once per worker) and returned."""

    sent_files: int = 0
    sent_bytes: int = 0
    fetched: dict[str, tuple[int, int]] = field(default_factory=dict)
    returned_files: int = 0
    returned_bytes: int = 0
    recording_bytes: int = 0
    largest: tuple[int, str] = (0, "")

    def add(self, outcome: RemoteOutcome, spec: IterationSpec) -> None:
        """Count one iteration's returned files and the blobs its worker fetched."""
        count, size = self.fetched.get(outcome.worker, (0, 0))
        self.fetched[outcome.worker] = (count + outcome.fetched, size + outcome.fetched_bytes)
        for artifact in outcome.artifacts:
            self.returned_files += 1
            self.returned_bytes += len(artifact.data)
            if artifact.path == outcome.recording:
                self.recording_bytes += len(artifact.data)
            if len(artifact.data) > self.largest[0]:
                where = _client_path(spec, outcome.recording, artifact.path)
                self.largest = (len(artifact.data), str(where))

    def summary(self) -> list[str]:
        """Lines for the run summary."""
        fetched = sum(c for c, _ in self.fetched.values())
        fetched_bytes = sum(b for _, b in self.fetched.values())
        lines = [
            f"dask: scattered {self.sent_files} file(s), {_size(self.sent_bytes)}; "
            f"{len(self.fetched)} worker(s) fetched {fetched} ({_size(fetched_bytes)}), "
            "each file at most once per worker",
            f"dask: returned {self.returned_files} file(s), {_size(self.returned_bytes)} "
            f"(recordings {_size(self.recording_bytes)}) into the --out folder",
        ]
        if self.largest[0]:
            lines.append(
                f"dask: largest returned file {self.largest[1]} ({_size(self.largest[0])})"
            )
        return lines


def _size(n: int) -> str:
    value = float(n)
    for unit in ("B", "kB", "MB", "GB"):
        if value < 1000 or unit == "GB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1000
    return f"{n} B"  # pragma: no cover - the loop always returns


@dataclass(frozen=True)
class DaskBackend:
    """An existing Dask distributed scheduler at ``address`` (``pip install distributed``);
    its workers need not see the client's files (see the module docstring). ``transfers``
    holds what the runs sent and got back."""

    address: str
    worker_timeout: float = 60.0
    """Wall seconds to wait for the first worker before giving up."""
    transfers: TransferLog = field(default_factory=TransferLog, compare=False, repr=False)

    def run(
        self, runner: IterationRunner, specs: Sequence[IterationSpec], on_result: OnResult
    ) -> list[IterationResult]:
        """Send every spec with its files to the cluster; results (and the files the
        iterations wrote) come back as they finish."""
        try:
            distributed: Any = importlib.import_module("distributed")
        except ImportError:
            raise RunnerError(
                "--backend dask needs the 'distributed' package (pip install dask distributed)"
            ) from None
        bundles: dict[int, Bundle] = {}
        blobs: dict[str, bytes] = {}
        made: dict[tuple[int, int], tuple[Bundle, dict[str, bytes]] | str] = {}
        unsent: dict[int, IterationResult] = {}
        for index, spec in enumerate(specs):
            key = (id(spec.scenario), id(spec.client))
            if key not in made:
                made[key] = _bundle_or_reason(spec)
            entry = made[key]
            if isinstance(entry, str):  # its world does not load here: nothing to send
                unsent[index] = failed_result(spec, entry)
                continue
            bundles[index], data = entry
            blobs.update(data)
        try:
            client = distributed.Client(self.address, set_as_default=False, timeout=30)
        except OSError as exc:
            raise RunnerError(f"cannot reach the Dask scheduler at {self.address}: {exc}") from None
        log = self.transfers
        results: dict[int, IterationResult] = {}
        try:
            try:
                client.wait_for_workers(1, timeout=self.worker_timeout)
            except TimeoutError:
                raise RunnerError(
                    f"no Dask worker joined the scheduler at {self.address} within "
                    f"{self.worker_timeout:g} s (start one: dask worker {self.address} "
                    "--nthreads 1)"
                ) from None
            dataset = f"harness-run-{uuid.uuid4().hex}"
            held = (
                client.scatter({BLOB_KEY_PREFIX + d: b for d, b in blobs.items()}) if blobs else {}
            )
            client.publish_dataset(**{dataset: {d: held[BLOB_KEY_PREFIX + d] for d in blobs}})
            log.sent_files += len(blobs)
            log.sent_bytes += sum(len(b) for b in blobs.values())
            for index, result in unsent.items():
                results[index] = result
                on_result(result)
            futures: dict[Any, int] = {
                client.submit(
                    run_on_worker, runner, specs[index], bundle, dataset, pure=False
                ): index
                for index, bundle in bundles.items()
            }
            try:
                for future in distributed.as_completed(list(futures), loop=client.loop):
                    index = futures[future]
                    spec = specs[index]
                    try:
                        outcome: RemoteOutcome = future.result()
                        result = receive(outcome, spec)
                        log.add(outcome, spec)
                    except Exception as exc:  # the worker died, the task was lost, a disk error
                        reason = f"Dask task failed: {type(exc).__name__}: {exc}"
                        result = failed_result(spec, reason)
                    results[index] = result
                    on_result(result)
            except interrupt.Interrupted as exc:
                # What came back is in --out already; the rest is cancelled with the client.
                finished = [results[i] for i in sorted(results)]
                raise interrupt.RunInterrupted(exc.signum, finished, len(specs)) from None
            client.unpublish_dataset(dataset)
            del held
        finally:
            client.close()
        return [results[i] for i in range(len(specs))]


def _bundle_or_reason(spec: IterationSpec) -> tuple[Bundle, dict[str, bytes]] | str:
    """The bundle of ``spec``, or why its files could not be gathered (a failed result's
    reason, as a runner's exception would be on a local worker)."""
    try:
        return collect_bundle(spec)
    except Exception as exc:
        return f"the files of the iteration could not be gathered: {type(exc).__name__}: {exc}"
