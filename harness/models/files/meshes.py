"""Meshes MuJoCo can read: binary STL, OBJ and MSH pass through; ASCII STL and the formats
in :data:`CONVERTIBLE` are converted to OBJ.

Conversion uses trimesh (imported only when a mesh needs converting: it costs ~0.5 s) into
a content-hashed cache, so a file is converted once per content, shared between processes
(written atomically). The cache folder is ``$HARNESS_CACHE_DIR`` if set, else
``$XDG_CACHE_HOME/harness/meshes``, else ``~/.cache/harness/meshes``.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from pathlib import Path

from harness.models.errors import MeshError
from harness.models.files.xmlsafe import check_size, parse_xml

__all__ = ["CONVERTIBLE", "PASS_THROUGH", "mesh_cache_dir", "prepare_mesh"]

PASS_THROUGH: frozenset[str] = frozenset({".stl", ".obj", ".msh"})
"""Extensions MuJoCo decodes itself."""
CONVERTIBLE: frozenset[str] = frozenset({".dae", ".ply", ".off", ".glb", ".gltf"})
"""Extensions converted to OBJ with trimesh."""


def mesh_cache_dir() -> Path:
    """The mesh cache folder (see the module docstring)."""
    explicit = os.environ.get("HARNESS_CACHE_DIR")
    if explicit:
        return Path(explicit)
    xdg = os.environ.get("XDG_CACHE_HOME")
    root = Path(xdg) if xdg else Path.home() / ".cache"
    return root / "harness" / "meshes"


def prepare_mesh(
    path: str | Path, *, cache_dir: str | Path | None = None, context: str = ""
) -> Path:
    """A path MuJoCo can load for the mesh at ``path`` (converting it if needed).

    ``context`` (file and element) prefixes error messages.
    """
    source = Path(path)
    prefix = f"{context}: " if context else ""
    ext = source.suffix.lower()
    if ext in PASS_THROUGH and not (ext == ".stl" and _is_ascii_stl(source)):
        return source
    if ext not in CONVERTIBLE and ext != ".stl":
        supported = sorted(PASS_THROUGH | CONVERTIBLE)
        raise MeshError(
            f"{prefix}unsupported mesh format {source.suffix!r} in {str(source)!r} "
            f"(supported: {', '.join(supported)})"
        )
    if ext == ".dae":  # COLLADA is XML: the same size limit as the models
        check_size(source)
    data = source.read_bytes()
    meter = _collada_meter(data, str(source)) if ext == ".dae" else 1.0
    key = ext.encode() + b"\0" + data
    if meter != 1.0:  # unit-1 files keep their cache names (and recordings their bytes)
        key += f"\0meter={meter!r}".encode()
    digest = hashlib.sha256(key).hexdigest()[:20]
    folder = Path(cache_dir) if cache_dir is not None else mesh_cache_dir()
    target = folder / f"{source.stem}-{digest}.obj"
    if target.is_file():
        return target
    obj = _convert(source, prefix, meter)
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".obj.tmp")
    with os.fdopen(fd, "w") as out:
        out.write(obj)
    os.replace(tmp, target)
    return target


def _is_ascii_stl(path: Path) -> bool:
    """MuJoCo decodes binary STL only: a file whose size is not 84 + 50 n bytes (n from
    its header) is ASCII."""
    try:
        size = path.stat().st_size
        with path.open("rb") as f:
            header = f.read(84)
    except OSError:
        return False  # MuJoCo reports the unreadable file
    if len(header) < 84:
        return header.lstrip().startswith(b"solid")
    return size != 84 + 50 * int.from_bytes(header[80:84], "little")


def _collada_meter(data: bytes, where: str) -> float:
    """The document's ``<asset><unit meter>`` (1 when absent or not a positive number): gz
    scales a whole COLLADA mesh by it, trimesh does not. Parsing checks for entities too."""
    root = parse_xml(data, where)
    for element in root:
        if isinstance(element.tag, str) and element.tag.rpartition("}")[2] == "asset":
            for unit in element:
                if isinstance(unit.tag, str) and unit.tag.rpartition("}")[2] == "unit":
                    try:
                        meter = float(unit.get("meter", "1"))
                    except ValueError:
                        return 1.0
                    return meter if math.isfinite(meter) and meter > 0 else 1.0
    return 1.0


def _convert(source: Path, prefix: str, meter: float = 1.0) -> str:
    import trimesh  # lazy: slow import, needed only for conversion

    try:
        loaded = trimesh.load(str(source), force="mesh", process=False)
    except Exception as exc:  # trimesh and its decoders raise anything
        raise MeshError(f"{prefix}cannot convert mesh {str(source)!r}: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{prefix}mesh {str(source)!r} has no triangles")
    if meter != 1.0:
        loaded.apply_scale(meter)  # type: ignore[no-untyped-call]
    text = loaded.export(file_type="obj", include_normals=False, include_texture=False)
    return str(text)
