"""Collision meshes as Gazebo collides them: a non-convex mesh becomes convex pieces.

MuJoCo collides a mesh geom as its convex hull, so a concave mesh (an arena's outer wall, a
room) is solid inside: a robot starting in it is pushed out with kilonewtons. Gazebo collides
the triangles. :func:`decompose_spec` closes the gap with CoACD (a maintained approximate
convex decomposition, ``coacd`` on PyPI): each colliding mesh geom whose convex hull lies
more than :data:`MAX_DEVIATION` from the mesh is split into convex pieces, each a
collision-only geom with the original's contact settings; the original geom stays where it
was with ``contype = conaffinity = 0``, so it still gives the body its mass and ray sensors
(lidar, depth: ``mj_ray`` intersects a mesh's own triangles) and cameras see the triangles.
The pieces are invisible (``rgba`` alpha 0: ``mj_ray`` and the renderer skip them) and
massless. A mesh whose hull is within the bound (a convex mesh) stays one geom.

The bound is absolute: CoACD's ``threshold`` is relative to the mesh's size (a 5 m wall at
its default 0.05 could be off by decimetres), so every result is measured: the one-sided
Hausdorff distance from the pieces to the mesh (points sampled on every piece's surface and
its vertices, their distance to the mesh's triangles, zero for points inside a closed mesh)
and the threshold is halved until it holds (:data:`THRESHOLDS`); a mesh that still misses it
keeps its best pieces with a :class:`ModelWarning` naming the mesh and the distance.

CoACD runs only on a mesh that needs it: the mesh's own convex hull is measured first (the
same one-sided distance), and a hull within the bound stays one geom (``kind`` ``"hull"`` in
the cache entry), as does a closed convex mesh (``"convex"``). CoACD itself is capped
(:data:`COACD_OPTIONS`: pieces, preprocessing and sampling resolution, tree search) so that a
detailed mesh takes seconds, not a quarter of an hour (turtlebot3_house's 5,764-triangle
``trash_can.dae`` took 911 s at CoACD's defaults on a 2-core machine); where the capped search
cannot reach the bound (it gave its most pieces, or the finest threshold missed), the
warning says how far it got.

Results are cached by content (the mesh bytes MuJoCo decodes, its scale, the parameters and
the CoACD version: :func:`cache_name`) in the mesh cache folder
(:func:`harness.models.files.meshes.mesh_cache_dir`), written atomically, so a world or a
robot is decomposed once per machine. A cold load measures the meshes the cache lacks (the
hull check, in the caller's process) and runs CoACD on those that need it in parallel
processes (:func:`workers_for`: at most the CPUs, ``$HARNESS_DECOMPOSE_WORKERS`` caps them, 1
keeps it in the caller's process), each mesh as the serial run does it, so the entries are
the same (the measurement is deterministic); one :class:`ModelWarning` ("decomposing N
meshes of ... (first load; cached in ...)") comes before CoACD runs. ``mesh_collision="hull"``
keeps MuJoCo's convex hull (the behaviour before decomposition).

A robot's pieces are in its link's body, so contacts, collision events and the
self-collision exclusions (adjacent links, SRDF pairs: body pairs) are the link's; an
unnamed collision geom's pieces are named ``<link>#<n>``.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal, cast

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.build.workers import WORKERS_VARIABLE, in_processes, workers_for
from harness.models.errors import MeshError, ModelStructureError, ModelWarning
from harness.models.files.meshes import mesh_cache_dir
from harness.vocabulary import MESH_COLLISION_MODES as _MODES
from harness.vocabulary import MeshCollisionMode

__all__ = [
    "COACD_OPTIONS",
    "DECOMPOSITION_FOLDER",
    "MAX_DEVIATION",
    "MESH_COLLISION_MODES",
    "THRESHOLDS",
    "WORKERS_VARIABLE",
    "Decomposition",
    "DecompositionKind",
    "MeshCollision",
    "cache_name",
    "check_mesh_collision",
    "decompose_mesh",
    "decompose_spec",
    "deviation",
    "entry_names",
    "workers_for",
]

MeshCollision = Literal["decompose", "hull"]
"""How a colliding mesh collides: ``decompose`` (convex pieces, the default) or ``hull``
(MuJoCo's convex hull of the whole mesh)."""
MESH_COLLISION_MODES: tuple[MeshCollision, ...] = cast("tuple[MeshCollision, ...]", _MODES)
"""The spellings of :class:`harness.vocabulary.MeshCollisionMode`."""
DECOMPOSITION_FOLDER = "decomposition"
"""The sources role (``source/decomposition/...`` in a recording) of the cached pieces a
load used: a rebuild reads them as its cache and never decomposes again."""

MAX_DEVIATION = 0.02
"""Metres: the pieces stay this close to the mesh's triangles (one-sided Hausdorff)."""
THRESHOLDS: tuple[float, ...] = (0.05, 0.025, 0.0125)
"""CoACD concavity thresholds tried in turn until the pieces are within the bound."""
COACD_OPTIONS: dict[str, int] = {
    "max_convex_hull": 32,
    "preprocess_resolution": 30,
    "resolution": 1000,
    "mcts_nodes": 10,
    "mcts_iterations": 60,
    "mcts_max_depth": 2,
}
"""CoACD's parameters besides the threshold: capped below its defaults (no limit on pieces,
preprocess resolution 50, sampling resolution 2000, 20 nodes, 150 iterations, depth 3) so that
a cold load stays within minutes; part of the cache key."""
_SAMPLES = 4000
"""Points sampled on each candidate piece's surface (plus its vertices)."""
_FORMAT = "harness-decompose-2"
_LEGACY_FORMAT = "harness-decompose-1"
"""Entries before :data:`COACD_OPTIONS` and ``kind``: still read (a recording carries them)."""
_DECODABLE = frozenset({".obj", ".stl"})


def check_mesh_collision(value: object, where: str) -> MeshCollision:
    """``value`` as a :data:`MeshCollision`, or one line naming ``where`` and the choices."""
    try:
        return MeshCollisionMode.parse(value, where).value
    except ValueError as exc:
        raise ModelStructureError(str(exc)) from None


DecompositionKind = Literal["convex", "hull", "pieces"]
"""What a mesh became: ``convex`` (closed and convex, or smaller than the bound: nothing
measured), ``hull`` (its convex hull measured within the bound: one geom, CoACD never ran) or
``pieces`` (CoACD's convex pieces)."""


@dataclass(frozen=True)
class Decomposition:
    """The convex pieces of one mesh (``pieces`` empty: its hull is within the bound)."""

    pieces: tuple[tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]], ...]
    deviation: float
    """Metres: the measured one-sided Hausdorff distance of the pieces (or the hull)."""
    threshold: float
    """The CoACD threshold that gave the pieces (0: none ran)."""
    cache_file: str = ""
    """The name of its cache file (``decompose-<digest>.npz``)."""
    kind: DecompositionKind = "pieces"
    """How the mesh collides (see :data:`DecompositionKind`)."""

    def _replace_cache(self, name: str) -> Decomposition:
        return replace(self, cache_file=name)


def _coacd_version() -> str:
    from importlib.metadata import version

    return version("coacd")


def _run_coacd(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], threshold: float
) -> list[tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]]:
    """CoACD's pieces of the mesh (deterministic: seed 0)."""
    import coacd  # lazy: a native library needed only when a mesh is decomposed

    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(vertices, faces), threshold=threshold, seed=0, **COACD_OPTIONS
    )
    return [(np.asarray(v, np.float64), np.asarray(f, np.int32)) for v, f in parts]


def deviation(pieces: Sequence[Any], mesh: Any) -> float:
    """The one-sided Hausdorff distance (metres) from the surfaces of ``pieces`` (trimesh
    meshes) to ``mesh``'s triangles; points inside a closed ``mesh`` count as 0."""
    import trimesh

    points = []
    for piece in pieces:
        sampled, _ = trimesh.sample.sample_surface(piece, _SAMPLES, seed=0)
        points.extend([sampled, piece.vertices])
    cloud = np.vstack(points)
    _, distance, _ = trimesh.proximity.closest_point(mesh, cloud)  # type: ignore[no-untyped-call]
    if mesh.is_watertight:
        distance[_contains(mesh, cloud)] = 0.0
    return float(distance.max(initial=0.0))


_RAY_DIRECTIONS = ((0.4395064455, 0.617598629942, 0.652231566745), (-0.5773, 0.5773, -0.5774))
"""Ray directions of the inside test: trimesh's default, then another fixed one."""


def _contains(mesh: Any, points: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """Which ``points`` are inside the closed ``mesh``, deterministically: trimesh's
    ``contains`` retries an ambiguous ray (one through an edge) in a random direction, so the
    same pieces measured twice could differ; here each point is tested along two fixed
    directions (both ways, as trimesh does) and is inside when either test says so (an
    ambiguous test says outside)."""
    from trimesh.ray.ray_util import contains_points

    inside = np.zeros(len(points), dtype=bool)
    for direction in _RAY_DIRECTIONS:
        inside |= contains_points(mesh.ray, points, check_direction=direction)
    return inside


def _load(data: bytes, suffix: str, scale: Sequence[float], where: str) -> Any:
    import trimesh

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=suffix.lstrip("."), force="mesh")
    except Exception as exc:  # trimesh and its decoders raise anything
        raise MeshError(f"{where}: cannot read the mesh to decompose it: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{where}: the mesh to decompose has no triangles")
    loaded.apply_scale(np.asarray(scale, dtype=np.float64))  # type: ignore[no-untyped-call]
    return loaded


@dataclass(frozen=True)
class _Job:
    """One mesh file to decompose: its bytes as MuJoCo decodes them, suffix, scale and the
    place its messages name."""

    data: bytes
    suffix: str
    scale: tuple[float, ...]
    where: str


_PARAMS: dict[str, Any] = {
    "max_deviation": MAX_DEVIATION,
    "thresholds": THRESHOLDS,
    "samples": _SAMPLES,
}


def cache_name(data: bytes, suffix: str, scale: Sequence[float] = (1.0, 1.0, 1.0)) -> str:
    """The cache file name (``decompose-<digest>.npz``) of the mesh file ``data`` scaled by
    ``scale`` under the current parameters and CoACD version: an entry under another name
    (made by another version) is not found, and the mesh is decomposed again."""
    return _cache_name(_FORMAT, {**_PARAMS, "coacd": COACD_OPTIONS}, data, suffix, scale)


def _cached(folder: Path, job: _Job) -> Decomposition | None:
    target = folder / cache_name(job.data, job.suffix, job.scale)
    cached = _read_cache(target) if target.is_file() else None
    if cached is None:  # a recording made before CoACD was capped carries the older entry
        legacy = folder / _cache_name(_LEGACY_FORMAT, _PARAMS, job.data, job.suffix, job.scale)
        cached = _read_cache(legacy) if legacy.is_file() else None
    return cached


def _store(folder: Path, job: _Job, result: Decomposition) -> Decomposition:
    target = folder / cache_name(job.data, job.suffix, job.scale)
    _write_cache(folder, target, result)
    return result._replace_cache(target.name)


def _decompose_jobs(
    jobs: Sequence[_Job], folder: Path, *, label: str = "", workers: int | None = None
) -> list[Decomposition]:
    """The decompositions of ``jobs``, from the cache where it has them; the others in
    parallel processes (see the module docstring), each stored in ``folder``. ``label``: what
    the meshes belong to, for the line before a cold decomposition (none when empty)."""
    results: list[Decomposition | None] = [_cached(folder, job) for job in jobs]
    pending: dict[str, list[int]] = {}  # cache name -> the jobs of that content
    for index, job in enumerate(jobs):
        if results[index] is None:
            pending.setdefault(cache_name(job.data, job.suffix, job.scale), []).append(index)
    todo: list[int] = []  # one job per content that needs CoACD
    for indexes in pending.values():
        job = jobs[indexes[0]]
        quick = _without_coacd(_load(job.data, job.suffix, job.scale, job.where))
        if quick is not None:
            stored = _store(folder, job, quick)
            for index in indexes:
                results[index] = stored
        else:
            todo.append(indexes[0])
    if todo:
        count = workers_for(len(todo), workers)
        if label:
            warnings.warn(
                f"decomposing {len(todo)} mesh{'es' if len(todo) > 1 else ''} of {label} "
                f"(first load; cached in {folder}{f', {count} processes' if count > 1 else ''})",
                ModelWarning,
                stacklevel=4,
            )
        found: dict[int, Decomposition] = {}
        if count > 1:
            largest = sorted(todo, key=lambda i: -len(jobs[i].data))
            arguments = {i: _arguments(jobs[i]) for i in largest}
            found = in_processes(_coacd_file, arguments, count, what="decomposing")
        for index in todo:  # serial, or what a broken pool left (the same function)
            if index not in found:
                found[index] = _coacd_file(*_arguments(jobs[index]))
        for first, result in found.items():
            job = jobs[first]
            stored = _store(folder, job, result)
            for index in pending[cache_name(job.data, job.suffix, job.scale)]:
                results[index] = stored
    done = [r for r in results if r is not None]
    assert len(done) == len(jobs)
    for job, result in zip(jobs, done, strict=True):
        if result.deviation > MAX_DEVIATION:
            warnings.warn(
                f"{job.where}: convex pieces stay {result.deviation * 1000:.0f} mm from the "
                f"mesh (bound {MAX_DEVIATION * 1000:.0f} mm) at CoACD threshold "
                f"{result.threshold:g}",
                ModelWarning,
                stacklevel=4,
            )
    return done


def decompose_mesh(
    data: bytes,
    suffix: str,
    scale: Sequence[float] = (1.0, 1.0, 1.0),
    *,
    cache_dir: str | Path | None = None,
    where: str = "mesh",
) -> Decomposition:
    """The :class:`Decomposition` of the mesh file ``data`` (``suffix`` ``.obj`` or
    ``.stl``) scaled by ``scale``, from the cache when it has it (see the module docstring)."""
    folder = Path(cache_dir) if cache_dir is not None else mesh_cache_dir()
    job = _Job(data, suffix, tuple(float(s) for s in scale), where)
    (result,) = _decompose_jobs([job], folder)
    return result


def _cache_name(
    form: str, params: dict[str, Any], data: bytes, suffix: str, scale: Sequence[float]
) -> str:
    header = json.dumps([form, _coacd_version(), params, [float(s) for s in scale], suffix.lower()])
    digest = hashlib.sha256(header.encode() + b"\0" + data).hexdigest()[:24]
    return f"decompose-{digest}.npz"


def _trivial(mesh: Any) -> Decomposition | None:
    """The mesh's :class:`Decomposition` when nothing needs measuring (``convex``: smaller
    than the bound, or closed and convex), else None."""
    if float(np.max(mesh.extents)) <= MAX_DEVIATION:
        return Decomposition((), 0.0, 0.0, kind="convex")
    if mesh.is_watertight and mesh.volume >= 0.999 * mesh.convex_hull.volume:
        return Decomposition((), 0.0, 0.0, kind="convex")  # nothing to measure
    return None


def _without_coacd(mesh: Any) -> Decomposition | None:
    """The mesh's :class:`Decomposition` when CoACD is not needed (``convex``, or ``hull``:
    its hull measured within the bound), else None."""
    trivial = _trivial(mesh)
    if trivial is not None:
        return trivial
    hull_deviation = deviation([mesh.convex_hull], mesh)
    if hull_deviation <= MAX_DEVIATION:
        return Decomposition((), hull_deviation, 0.0, kind="hull")
    return None


def _coacd_pieces(mesh: Any) -> Decomposition:
    """CoACD's pieces of a mesh whose hull misses the bound: the thresholds in turn until the
    pieces are within it (or CoACD gave its most pieces), the best kept."""
    import trimesh

    best: Decomposition | None = None
    for threshold in THRESHOLDS:
        parts = _run_coacd(np.asarray(mesh.vertices), np.asarray(mesh.faces), threshold)
        pieces = [trimesh.Trimesh(v, f, process=False) for v, f in parts]
        measured = deviation(pieces, mesh)
        if best is None or measured < best.deviation:
            best = Decomposition(tuple(parts), measured, threshold)
        if measured <= MAX_DEVIATION or len(parts) >= COACD_OPTIONS["max_convex_hull"]:
            break  # within the bound, or capped: a finer threshold asks for pieces it cannot have
    assert best is not None
    return best


def _decompose(mesh: Any) -> Decomposition:
    """What ``mesh`` becomes (see :data:`DecompositionKind`)."""
    return _without_coacd(mesh) or _coacd_pieces(mesh)


def _arguments(job: _Job) -> tuple[bytes, str, tuple[float, ...], str]:
    return job.data, job.suffix, job.scale, job.where


def _coacd_file(data: bytes, suffix: str, scale: tuple[float, ...], where: str) -> Decomposition:
    """:func:`_coacd_pieces` of a mesh file: a worker process's job, and the serial run's
    (the mesh read from its bytes either way, so the entries are the same)."""
    return _coacd_pieces(_load(data, suffix, scale, where))


def _read_cache(path: Path) -> Decomposition | None:
    try:
        with np.load(path, allow_pickle=False) as npz:
            count = int(npz["count"])
            pieces = tuple(
                (np.asarray(npz[f"v{i}"], np.float64), np.asarray(npz[f"f{i}"], np.int32))
                for i in range(count)
            )
            if "kind" in npz.files:
                kind = str(npz["kind"])
                if kind not in ("convex", "hull", "pieces"):
                    return None
            else:  # a legacy entry
                kind = "pieces" if count else "hull" if float(npz["deviation"]) else "convex"
            return Decomposition(
                pieces,
                float(npz["deviation"]),
                float(npz["threshold"]),
                path.name,
                cast("DecompositionKind", kind),
            )
    except (OSError, ValueError, KeyError):
        return None  # unreadable or partial: decompose again


def _write_cache(folder: Path, target: Path, result: Decomposition) -> None:
    arrays: dict[str, Any] = {
        "count": np.array(len(result.pieces)),
        "deviation": np.array(result.deviation),
        "threshold": np.array(result.threshold),
        "kind": np.array(result.kind),
    }
    for index, (vertices, faces) in enumerate(result.pieces):
        arrays[f"v{index}"], arrays[f"f{index}"] = vertices, faces
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".npz.tmp")
    with os.fdopen(fd, "wb") as out:
        np.savez(out, **arrays)
    os.replace(tmp, target)


_COPIED = (
    "contype", "conaffinity", "condim", "priority", "friction", "solmix", "solref", "solimp",
    "margin", "gap", "group", "pos", "quat",
)  # fmt: skip


def _colliding_meshes(spec: mujoco.MjSpec) -> list[mujoco.MjsGeom]:
    return [
        geom
        for geom in spec.geoms
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH and (geom.contype or geom.conaffinity)
    ]


def decompose_spec(
    spec: mujoco.MjSpec,
    *,
    mode: MeshCollision = "decompose",
    source: str,
    cache_dir: str | Path | None = None,
    workers: int | None = None,
) -> dict[str, bytes]:
    """Replace each colliding non-convex mesh geom of ``spec`` by convex pieces (see the
    module docstring); returns the cache files a rebuild needs, as sources
    (``decomposition/<file>`` -> bytes: a recording attaches them, a rebuild reads them as
    its cache; a closed convex mesh's entry is left out, deciding it again costs a volume).
    ``mode="hull"`` changes nothing. The meshes must be in ``spec.assets`` (as
    :mod:`harness.models.files.assets` puts them); a mesh given by its vertices, in a format
    MuJoCo decodes alone (``.msh``) or with a ``refpos``/``refquat`` is left as its hull.
    Meshes not in the cache are decomposed in up to ``workers`` processes
    (:func:`workers_for`), after one :class:`ModelWarning` naming ``source``."""
    mode = check_mesh_collision(mode, source)
    used: dict[str, bytes] = {}
    if mode == "hull":
        return used
    geoms = _colliding_meshes(spec)
    if not geoms:
        return used
    assets = dict(spec.assets)
    meshes = {mesh.name: mesh for mesh in spec.meshes}
    folder = Path(cache_dir) if cache_dir is not None else mesh_cache_dir()
    jobs: dict[str, _Job] = {}
    for geom in geoms:
        mesh = meshes.get(str(geom.meshname))
        if mesh is not None and mesh.name not in jobs:
            job = _job(mesh, assets, source)
            if job is not None:
                jobs[mesh.name] = job
    decomposed = _decompose_jobs(list(jobs.values()), folder, label=source, workers=workers)
    results = dict(zip(jobs, decomposed, strict=True))
    pieces_of: dict[str, list[str]] = {}
    taken = {str(g.name) for g in spec.geoms if g.name}
    for geom in geoms:
        mesh = meshes.get(str(geom.meshname))
        if mesh is None or mesh.name not in results:
            continue
        result = results[mesh.name]
        if mesh.name not in pieces_of:
            pieces_of[mesh.name] = _add_piece_meshes(spec, mesh, result)
            if result.cache_file and result.kind != "convex":
                with contextlib.suppress(OSError):  # removed meanwhile: replay uses model.mjb
                    used[f"{DECOMPOSITION_FOLDER}/{result.cache_file}"] = (
                        folder / result.cache_file
                    ).read_bytes()
        names = pieces_of[mesh.name]
        if not names:
            continue
        body = geom.parent
        for index, name in enumerate(names):
            piece = body.add_geom(name=_piece_name(geom, index, taken))
            for attribute in _COPIED:
                setattr(piece, attribute, getattr(geom, attribute))
            if geom.frame is not None:
                piece.set_frame(geom.frame)
            piece.type = mujoco.mjtGeom.mjGEOM_MESH
            piece.meshname = name
            piece.rgba = [0.5, 0.5, 0.5, 0.0]  # unseen by mj_ray and the renderer
            piece.density = 0.0
            piece.mass = 0.0
        geom.contype = 0
        geom.conaffinity = 0
    return used


def entry_names(spec: mujoco.MjSpec, source: str = "model") -> dict[str, str]:
    """Mesh name -> the cache file name (:func:`cache_name`) :func:`decompose_spec` looks up
    for each colliding mesh of ``spec`` it would decompose (nothing is measured)."""
    assets = dict(spec.assets)
    meshes = {mesh.name: mesh for mesh in spec.meshes}
    names: dict[str, str] = {}
    for geom in _colliding_meshes(spec):
        mesh = meshes.get(str(geom.meshname))
        job = _job(mesh, assets, source) if mesh is not None else None
        if mesh is not None and job is not None:
            names[mesh.name] = cache_name(job.data, job.suffix, job.scale)
    return names


def _piece_name(geom: mujoco.MjsGeom, index: int, taken: set[str]) -> str:
    """A piece's name: ``<geom>#<index>``; of an unnamed geom in a named body (a URDF link's
    collision) ``<body>#<n>``, unique in the model, so that a contact with it names the link
    rather than ``geom<id>``; "" for an unnamed geom in the world body."""
    if geom.name:
        return f"{geom.name}#{index}"
    body = geom.parent
    if not body.name or body.name == "world":
        return ""
    number = 0
    while f"{body.name}#{number}" in taken:
        number += 1
    taken.add(f"{body.name}#{number}")
    return f"{body.name}#{number}"


def _job(mesh: mujoco.MjsMesh, assets: dict[str, bytes], source: str) -> _Job | None:
    """The :class:`_Job` of ``mesh``, or None when it is left as its hull."""
    suffix = Path(str(mesh.file)).suffix.lower()
    data = assets.get(str(mesh.file))
    plain_ref = np.allclose(mesh.refpos, 0.0) and np.allclose(mesh.refquat, [1, 0, 0, 0])
    if data is None or suffix not in _DECODABLE or not plain_ref:
        return None
    where = f'{source}: <mesh name="{mesh.name}">'
    return _Job(data, suffix, tuple(float(s) for s in mesh.scale), where)


def _add_piece_meshes(
    spec: mujoco.MjSpec, mesh: mujoco.MjsMesh, result: Decomposition
) -> list[str]:
    """The names of the piece meshes added to ``spec`` for ``mesh``."""
    names = []
    for index, (vertices, faces) in enumerate(result.pieces):
        name = f"{mesh.name}#{index}"
        spec.add_mesh(
            name=name,
            uservert=vertices.reshape(-1).tolist(),
            userface=faces.reshape(-1).tolist(),
        )
        names.append(name)
    return names
