"""Files a model references (meshes, textures, height fields, skins) as in-memory assets under
location-independent names, so a compiled model never depends on where files are installed.

MuJoCo writes the path it read a file from into the compiled model (the MJCF ``file``
attributes and the ``mjb``): an absolute path into a venv or a mesh cache makes the model
differ between two checkouts of the same project. Instead each file enters the
:class:`mujoco.MjSpec` through ``spec.assets`` (MuJoCo's in-memory file system) under the name
``<stem>-<first 16 hex digits of the sha256 of its bytes><suffix>``: the same bytes give the
same name wherever they live, and two different files never share one. Meshes are the bytes
MuJoCo decodes (converted OBJ for DAE, ASCII STL and the like, see
:mod:`harness.models.files.meshes`).
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import mujoco

from harness.models.errors import ResolveError
from harness.models.files.confine import check_confined
from harness.models.files.meshes import CONVERTIBLE, PASS_THROUGH, prepare_mesh

__all__ = ["Asset", "asset_name", "embed_files", "mesh_asset"]

_UNSAFE = re.compile(r"[^A-Za-z0-9_.\-]")


class Asset(NamedTuple):
    """A file's bytes and the location-independent name it has in a spec's assets."""

    name: str
    data: bytes


def asset_name(filename: str, data: bytes) -> str:
    """``<stem>-<16 hex of sha256(data)><suffix>`` of ``filename`` (characters other than
    letters, digits, ``_``, ``.`` and ``-`` in the stem become ``_``)."""
    path = Path(filename)
    stem = _UNSAFE.sub("_", path.stem) or "file"
    return f"{stem}-{hashlib.sha256(data).hexdigest()[:16]}{path.suffix.lower()}"


def _read(path: Path, prefix: str, what: str) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise ResolveError(f"{prefix}cannot read {what} {str(path)!r}: {exc.strerror}") from None


def mesh_asset(
    path: str | Path, *, cache_dir: str | Path | None = None, context: str = ""
) -> Asset:
    """The mesh at ``path`` as MuJoCo decodes it (converted if needed, see
    :func:`harness.models.files.meshes.prepare_mesh`), named after the source file's stem."""
    source = Path(path)
    decodable = prepare_mesh(source, cache_dir=cache_dir, context=context)
    data = _read(decodable, f"{context}: " if context else "", "mesh")
    return Asset(asset_name(source.stem + decodable.suffix, data), data)


def _folder(spec: mujoco.MjSpec, directory: str) -> Path:
    """Where MuJoCo looks for a relative file: the compiler directory if absolute, else the
    model file's folder joined with it (MJCF ``<compiler meshdir>`` rules)."""
    folder = Path(directory)
    return folder if folder.is_absolute() else Path(spec.modelfiledir) / folder


class _FileRef(NamedTuple):
    """One file reference of a spec: an element's ``file``, or entry ``cube`` of a texture's
    ``cubefiles``."""

    kind: str
    element: Any  # MjsMesh, MjsHField, MjsSkin or MjsTexture
    cube: int | None = None

    @property
    def file(self) -> str:
        return str(self.element.file if self.cube is None else self.element.cubefiles[self.cube])

    def set(self, value: str) -> None:
        if self.cube is None:
            self.element.file = value
        else:
            files = list(self.element.cubefiles)
            files[self.cube] = value
            self.element.cubefiles = files


def _file_refs(spec: mujoco.MjSpec) -> Iterator[_FileRef]:
    for kind, elements in (
        ("mesh", spec.meshes),
        ("hfield", spec.hfields),
        ("skin", spec.skins),
        ("texture", spec.textures),
    ):
        for element in elements:
            yield _FileRef(kind, element)
    for texture in spec.textures:
        for index in range(len(texture.cubefiles)):
            yield _FileRef("texture", texture, index)


def embed_files(spec: mujoco.MjSpec, *, source: str, cache_dir: str | Path | None = None) -> None:
    """Put every file ``spec`` references into ``spec.assets`` under its
    :func:`asset_name` and point the element at it (a file already in ``spec.assets`` stays
    as it is); then clear the spec's model folder and
    compiler directories (MuJoCo would write them into the compiled model, also for the
    assets of specs attached to this one later): the spec reads no file any more.

    Files are found as MuJoCo finds them (``strippath``, ``meshdir``, ``texturedir``, the
    model file's folder); meshes in a format MuJoCo cannot decode are converted (cached in
    ``cache_dir``). ``source`` names the model file in errors (:class:`ResolveError`,
    :class:`MeshError`).
    """
    assets = dict(spec.assets)
    for ref in _file_refs(spec):
        kind, name, file = ref.kind, ref.element.name, ref.file
        if not file or file in assets:  # nothing, or already in memory
            continue
        context = f'{source}: <{kind} name="{name}">' if name else f"{source}: <{kind}>"
        reference = Path(Path(file).name if spec.strippath else file)
        directory = spec.texturedir if kind == "texture" else spec.meshdir
        path = reference if reference.is_absolute() else _folder(spec, directory) / reference
        check_confined(path, file, context=context, what=kind)
        if not path.is_file():
            raise ResolveError(f"{context}: {kind} not found: {str(path)!r} (from {file!r})")
        if kind == "mesh" and path.suffix.lower() in PASS_THROUGH | CONVERTIBLE:
            asset = mesh_asset(path, cache_dir=cache_dir, context=context)
        else:
            data = _read(path, f"{context}: ", kind)
            asset = Asset(asset_name(path.name, data), data)
        assets[asset.name] = asset.data
        ref.set(asset.name)
    if assets:
        spec.assets = assets
    spec.modelfiledir = ""
    spec.meshdir = ""
    spec.texturedir = ""
