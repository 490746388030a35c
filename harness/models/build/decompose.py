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
the CoACD version) in the mesh cache folder (:func:`harness.models.files.meshes.mesh_cache_dir`),
written atomically, so a world is decomposed once per machine. ``mesh_collision="hull"``
keeps MuJoCo's convex hull (the behaviour before decomposition).
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
    "Decomposition",
    "DecompositionKind",
    "MeshCollision",
    "check_mesh_collision",
    "decompose_mesh",
    "decompose_spec",
    "deviation",
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
        distance[mesh.contains(cloud)] = 0.0
    return float(distance.max(initial=0.0))


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
    params: dict[str, Any] = {
        "max_deviation": MAX_DEVIATION,
        "thresholds": THRESHOLDS,
        "samples": _SAMPLES,
    }
    folder = Path(cache_dir) if cache_dir is not None else mesh_cache_dir()
    target = folder / _cache_name(_FORMAT, {**params, "coacd": COACD_OPTIONS}, data, suffix, scale)
    cached = _read_cache(target) if target.is_file() else None
    if cached is None:  # a recording made before CoACD was capped carries the older entry
        legacy = folder / _cache_name(_LEGACY_FORMAT, params, data, suffix, scale)
        cached = _read_cache(legacy) if legacy.is_file() else None
    if cached is None:
        cached = _decompose(_load(data, suffix, scale, where))
        _write_cache(folder, target, cached)
        cached = cached._replace_cache(target.name)
    if cached.deviation > MAX_DEVIATION:
        warnings.warn(
            f"{where}: convex pieces stay {cached.deviation * 1000:.0f} mm from the mesh "
            f"(bound {MAX_DEVIATION * 1000:.0f} mm) at CoACD threshold {cached.threshold:g}",
            ModelWarning,
            stacklevel=3,
        )
    return cached


def _cache_name(
    form: str, params: dict[str, Any], data: bytes, suffix: str, scale: Sequence[float]
) -> str:
    header = json.dumps([form, _coacd_version(), params, [float(s) for s in scale], suffix.lower()])
    digest = hashlib.sha256(header.encode() + b"\0" + data).hexdigest()[:24]
    return f"decompose-{digest}.npz"


def _decompose(mesh: Any) -> Decomposition:
    import trimesh

    extent = float(np.max(mesh.extents))
    if extent <= MAX_DEVIATION:
        return Decomposition((), 0.0, 0.0, kind="convex")
    hull = mesh.convex_hull
    if mesh.is_watertight and mesh.volume >= 0.999 * hull.volume:
        return Decomposition((), 0.0, 0.0, kind="convex")  # nothing to measure
    hull_deviation = deviation([hull], mesh)
    if hull_deviation <= MAX_DEVIATION:
        return Decomposition((), hull_deviation, 0.0, kind="hull")
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
) -> dict[str, bytes]:
    """Replace each colliding non-convex mesh geom of ``spec`` by convex pieces (see the
    module docstring); returns the cache files used, as sources
    (``decomposition/<file>`` -> bytes: a recording attaches them, a rebuild reads them as
    its cache). ``mode="hull"`` changes nothing. The meshes must be in ``spec.assets`` (as
    :mod:`harness.models.files.assets` puts them); a mesh given by its vertices, in a format MuJoCo
    decodes alone (``.msh``) or with a ``refpos``/``refquat`` is left as its hull."""
    mode = check_mesh_collision(mode, source)
    used: dict[str, bytes] = {}
    if mode == "hull":
        return used
    geoms = _colliding_meshes(spec)
    if not geoms:
        return used
    assets = dict(spec.assets)
    meshes = {mesh.name: mesh for mesh in spec.meshes}
    pieces_of: dict[str, list[str]] = {}
    folder = Path(cache_dir) if cache_dir is not None else mesh_cache_dir()
    for geom in geoms:
        mesh = meshes.get(str(geom.meshname))
        if mesh is None:
            continue
        if mesh.name not in pieces_of:
            pieces_of[mesh.name], cache_file = _piece_meshes(spec, mesh, assets, source, folder)
            if cache_file:
                with contextlib.suppress(OSError):  # removed meanwhile: replay uses model.mjb
                    used[f"{DECOMPOSITION_FOLDER}/{cache_file}"] = (
                        folder / cache_file
                    ).read_bytes()
        names = pieces_of[mesh.name]
        if not names:
            continue
        body = geom.parent
        for index, name in enumerate(names):
            piece = body.add_geom(name=f"{geom.name}#{index}" if geom.name else "")
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


def _piece_meshes(
    spec: mujoco.MjSpec,
    mesh: mujoco.MjsMesh,
    assets: dict[str, bytes],
    source: str,
    cache_dir: Path,
) -> tuple[list[str], str]:
    """The names of the piece meshes added for ``mesh`` and its cache file's name."""
    suffix = Path(str(mesh.file)).suffix.lower()
    data = assets.get(str(mesh.file))
    plain_ref = np.allclose(mesh.refpos, 0.0) and np.allclose(mesh.refquat, [1, 0, 0, 0])
    if data is None or suffix not in _DECODABLE or not plain_ref:
        return [], ""
    where = f'{source}: <mesh name="{mesh.name}">'
    result = decompose_mesh(data, suffix, tuple(mesh.scale), cache_dir=cache_dir, where=where)
    names = []
    for index, (vertices, faces) in enumerate(result.pieces):
        name = f"{mesh.name}#{index}"
        spec.add_mesh(
            name=name,
            uservert=vertices.reshape(-1).tolist(),
            userface=faces.reshape(-1).tolist(),
        )
        names.append(name)
    return names, result.cache_file
