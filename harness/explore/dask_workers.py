"""Engines as Dask tasks: ``harness explore --backend dask --scheduler ADDRESS``.

One task per ``--workers`` engine (worker ``i`` seeds ``seed + i``), spread over the
cluster's workers; the stop flag is a ``distributed.Event`` named for the search, so the
first engine to find a failure stops the others' generation wherever they run. The deadline
travels as wall-clock time (each worker converts it to its own monotonic clock).

The workers need not see the client's files: the scenario's files travel as ``harness run
--backend dask`` sends them (:mod:`harness.scenario.dask_backend`). On the client,
:func:`harness.scenario.collect_bundle` lists what the scenario as written reads (the scenario
file, robot and world files, meshes, includes, ``package.xml``\\ s, the client program's
script); each distinct file is scattered once (key ``harness-blob-<sha256>``). On the worker,
the engine fetches the blobs its cache lacks, checks every hash, materialises the tree that
mirrors the client's paths (:func:`harness.scenario.verified_tree`) and explores the
scenario there: its relative references resolve inside the tree, its absolute ones the bundle
holds are mirrored into it, the package search variables are the client's, mirrored. Each
engine writes its scratch, kept examples and example database in a folder of the worker's
own; the kept examples (scenario and recording of each failure's first example and of the
kept passing ones) come back with the engine's outcome into ``--out``'s work folder, their
paths the client's. Files a parameter's *other* values name (a choice between two robot
files) do not travel: only what the scenario as written reads.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import math
import os
import shlex
import shutil
import threading
import time
import uuid
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from harness.explore.engine import EngineOutcome
from harness.explore.episode import Example
from harness.explore.errors import ExploreError

__all__ = ["POLL_SECONDS", "DaskFlag", "Shipment", "dask_search", "run_dask_engine"]

_ENV = threading.Lock()  # one engine per worker process sets the package search variables


POLL_SECONDS = 0.1
"""How often an engine asks the scheduler whether the stop flag is set (at most)."""


class DaskFlag:
    """A :class:`~harness.explore.engine.StopFlag` over a ``distributed.Event``. Asking the
    scheduler is a round trip (about a millisecond, and the scheduler's time): an engine
    asks at most every ``poll`` seconds and, once it has seen the flag set, never again;
    another engine's stop reaches it within ``poll`` seconds."""

    def __init__(self, name: str, poll: float = POLL_SECONDS) -> None:
        distributed: Any = importlib.import_module("distributed")
        self._event: Any = distributed.Event(name)
        self._poll = poll
        self._next = -math.inf
        self._seen = False

    def is_set(self) -> bool:
        if not self._seen:
            now = time.monotonic()
            if now >= self._next:
                self._seen = bool(self._event.is_set())
                self._next = now + self._poll
        return self._seen

    def set(self) -> None:
        self._event.set()
        self._seen = True


@dataclass(frozen=True)
class Shipment:
    """The scenario's files as sent: the bundle (manifest) and the dataset holding the
    scattered blobs."""

    bundle: Any
    dataset: str


@dataclass(frozen=True)
class _Returned:
    """An engine's outcome with the kept examples' files (path relative to the engine's
    work folder -> bytes) and that folder on the worker."""

    outcome: EngineOutcome
    files: tuple[tuple[str, bytes], ...]
    work: str


def _fetch(dataset: str, digests: Sequence[str]) -> list[bytes]:
    distributed: Any = importlib.import_module("distributed")
    client = distributed.get_client()
    held: dict[str, Any] = client.get_dataset(dataset)
    data: list[bytes] = client.gather([held[d] for d in digests])
    return data


def _tree(shipment: Shipment) -> Path:
    """The shipment materialised on this worker (blobs fetched once, every hash checked)."""
    from harness.scenario import BlobStore, unverified_blobs, verified_tree, worker_dir

    base = worker_dir()
    store = BlobStore(base / "blobs")
    bundle = shipment.bundle
    missing = unverified_blobs(store, [f.sha256 for f in bundle.files])
    if missing:
        for digest, data in zip(missing, _fetch(shipment.dataset, missing), strict=True):
            store.put(digest, data)
    tree: Path = verified_tree(bundle, store, base / "trees")
    return tree


def _localise(document: Mapping[str, Any], bundle: Any, root: Path) -> dict[str, Any]:
    """The plan's ``document`` with every absolute path the bundle covers mirrored into
    ``root`` (the client command's words one by one)."""
    from harness.scenario import mirror

    def path(text: str) -> str:
        if os.path.isabs(text) and bundle.covers(Path(text)):
            return str(mirror(text, root))
        return text

    def walk(value: Any) -> Any:
        if isinstance(value, str):
            return path(value)
        if isinstance(value, Mapping):
            return {k: walk(v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            return [walk(v) for v in value]
        return value

    doc: dict[str, Any] = walk(document)
    client = doc.get("client")
    command = client.get("command") if isinstance(client, dict) else None
    if isinstance(command, str) and isinstance(client, dict):
        words = shlex.split(command)
        moved = [path(w) for w in words]
        if moved != words:
            client["command"] = shlex.join(moved)
    return doc


@contextlib.contextmanager
def _package_env(bundle: Any, root: Path) -> Iterator[None]:
    from harness.scenario import bundle_env

    with _ENV:
        saved = {var: os.environ.get(var) for var, _ in bundle.env}
        try:
            _set_env(bundle_env(bundle, root))
            yield
        finally:
            _set_env(saved)


def _set_env(values: Mapping[str, str | None]) -> None:
    for var, value in values.items():
        if value is None:
            os.environ.pop(var, None)
        else:
            os.environ[var] = value


def _kept_files(work: Path) -> tuple[tuple[str, bytes], ...]:
    return tuple(
        (p.relative_to(work).as_posix(), p.read_bytes())
        for p in sorted(work.rglob("*"))
        if p.is_file() and "kept" in p.relative_to(work).parts
    )


def run_dask_engine(
    source: str,
    options: Any,
    worker: int,
    wall_deadline: float | None,
    event: str,
    shipment: Shipment | None = None,
) -> Any:
    """One engine on a Dask worker (a task). With ``shipment``: the scenario's files come
    from it (see the module docstring) and the kept examples go back with the outcome."""
    from harness.explore.engine import run_engine
    from harness.explore.plan import load_plan
    from harness.explore.workers import engine_options, episode_runner, run_worker
    from harness.scenario import mirror, warm_clients, worker_dir

    deadline = None
    if wall_deadline is not None:
        deadline = time.monotonic() + (wall_deadline - time.time())
    if shipment is None:
        with warm_clients(options.fast):
            return run_worker(Path(source), options, worker, deadline, DaskFlag(event))
    tree = _tree(shipment)
    work = worker_dir() / "explore" / uuid.uuid4().hex
    local = replace(options, work=work, database=work / "database")
    try:
        with _package_env(shipment.bundle, tree), warm_clients(local.fast):
            plan = load_plan(mirror(source, tree))
            plan = replace(plan, document=_localise(plan.document, shipment.bundle, tree))
            outcome = run_engine(
                plan,
                episode_runner(plan, local, worker),
                engine_options(local, worker, deadline),
                DaskFlag(event),
            )
        return _Returned(outcome, _kept_files(work), str(work))
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _ship(source: Path, client: Any) -> Shipment:
    """Collect the scenario's files (as written) and scatter them to the cluster."""
    import tempfile

    from harness.scenario import (
        BLOB_KEY_PREFIX,
        collect_bundle,
        iteration_specs,
        load_run_file,
    )

    with tempfile.TemporaryDirectory(prefix="harness-explore-") as tmp:
        spec = iteration_specs(load_run_file(source), Path(tmp), iterations=1)[0]
        bundle, blobs = collect_bundle(spec)
    dataset = f"harness-explore-{uuid.uuid4().hex}"
    held = client.scatter({BLOB_KEY_PREFIX + d: b for d, b in blobs.items()}) if blobs else {}
    client.publish_dataset(**{dataset: {d: held[BLOB_KEY_PREFIX + d] for d in blobs}})
    return Shipment(bundle, dataset)


def _received(returned: _Returned, work: Path, worker: int) -> EngineOutcome:
    """The outcome with its kept examples written under ``work/worker-<i>/`` and their paths
    the client's."""
    remote = Path(returned.work)
    for relative, data in returned.files:
        target = work / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)

    def moved(example: Example | None) -> Example | None:
        if example is None or example.kept is None:
            return example
        kept = Path(example.kept)
        if kept.is_relative_to(remote):
            return replace(example, kept=str(work / kept.relative_to(remote)))
        return example

    outcome = returned.outcome
    examples = [moved(e) for e in outcome.examples]
    failures = {
        sig: dataclasses.replace(
            track,
            first=moved(track.first) or track.first,
            path=[moved(e) or e for e in track.path],
            minimal=moved(track.minimal),
        )
        for sig, track in outcome.failures.items()
    }
    return dataclasses.replace(
        outcome, examples=[e for e in examples if e is not None], failures=failures
    )


def dask_search(source: Path, options: Any, deadline: float | None) -> list[EngineOutcome]:
    """Run ``options.workers`` engines on the cluster at ``options.scheduler``, the
    scenario's files shipped to them (see the module docstring)."""
    try:
        distributed: Any = importlib.import_module("distributed")
    except ImportError:
        raise ExploreError(
            "--backend dask needs the dask extra (pip install 'harness[dask]')"
        ) from None
    wall_deadline = None if deadline is None else time.time() + (deadline - time.monotonic())
    event = f"harness-explore-{uuid.uuid4().hex}"
    local = replace(options, scheduler=None)
    try:
        client: Any = distributed.Client(options.scheduler, timeout=10, set_as_default=False)
    except OSError as exc:
        raise ExploreError(f"--scheduler {options.scheduler}: cannot connect: {exc}") from None
    with client:
        try:
            shipment = _ship(source, client)
        except Exception as exc:
            raise ExploreError(
                f"--backend dask: the files of {source} could not be gathered: "
                f"{type(exc).__name__}: {exc}"
            ) from None
        futures = [
            client.submit(
                run_dask_engine,
                str(source),
                local,
                i,
                wall_deadline,
                event,
                shipment,
                pure=False,
                key=f"harness-explore-{event[-8:]}-{i}",
            )
            for i in range(options.workers)
        ]
        try:
            returned: list[_Returned] = client.gather(futures)
        except Exception as exc:
            raise ExploreError(f"--backend dask: an engine failed: {exc}") from None
        with contextlib.suppress(Exception):
            client.unpublish_dataset(shipment.dataset)
    return [_received(r, options.work, i) for i, r in enumerate(returned)]
