"""The mesh files a robot's URDF source references, as attachments another machine can use.

The compiled model (``model.mjb``) holds every mesh as MuJoCo decoded it, which is all a
bit-exact replay needs; but rebuilding the robot from its sources (``source/model/...``), on a
machine without the robot's package, needs the mesh files too. :func:`mesh_attachments`
resolves each ``<mesh filename=...>`` of the URDF sources as loading did
(:func:`harness.models.files.resolve.resolve_uri`: ``ROS_PACKAGE_PATH``, the folders above the
file) and names it where the rebuild looks first (replay writes ``source/`` attachments into
one folder): ``package://pkg/rest`` as ``source/pkg/rest`` (the folder named like the package
next to ``model/``), a relative path as ``source/`` + the path from ``model/``. References that
cannot be resolved here, or only through an explicit package map, absolute paths and
``file://`` URIs are left out (the recording still replays from ``model.mjb``).

A robot loaded without its visuals (the default; a session loads a robot whose sensors render,
a camera, with them) compiles no visual geom, so its rebuild needs no visual-only file:
:func:`visual_only_attachments` names the attachments of the meshes only ``<visual>`` elements
reference and of every ``<texture>``, which the recorder then leaves out (both spellings:
``source/<pkg>/...`` and a xacro robot's ``source/package/<pkg>/...``).
"""

from __future__ import annotations

import posixpath
from collections.abc import Mapping
from pathlib import Path

from harness.errors import HarnessError
from harness.recording.layout import ATTACHMENT_SOURCE_PREFIX

__all__ = ["mesh_attachment_name", "mesh_attachments", "visual_only_attachments"]

_ROLES = ("model", "scene", "srdf")
"""Folders of ``source/`` the loader's own roles use: no package may take their name."""


def _target(uri: str) -> str | None:
    """The ``source/``-relative name a reference resolves under after a rebuild."""
    if uri.startswith("package://"):
        name, _, rest = uri[len("package://") :].lstrip("/").partition("/")
        path = posixpath.normpath(f"{name}/{rest}")
        if not name or name in _ROLES or path.startswith(("..", "/")) or path.split("/")[0] != name:
            return None
        return path
    if "://" in uri or uri.startswith("/") or not uri:
        return None
    path = posixpath.normpath(f"model/{uri}")
    return None if path.startswith(("..", "/")) else path


def mesh_attachment_name(uri: str) -> str | None:
    """The attachment a mesh reference of a URDF model source is recorded under
    (``source/...``), or ``None`` when such references are not attached."""
    target = _target(uri)
    return None if target is None else ATTACHMENT_SOURCE_PREFIX + target


def mesh_attachments(sources: Mapping[str, bytes], source_path: str | None) -> dict[str, bytes]:
    """``source/...`` attachments of the meshes referenced by the URDF model files among
    ``sources`` (a loaded robot's ``sources``), resolved from ``source_path`` (the model
    file loading read: ``RobotModel.source``). Best effort: what cannot be resolved is left
    out (see the module docstring)."""
    if not source_path or not Path(source_path).is_file():
        return {}
    from harness.models.files.resolve import resolve_uri
    from harness.models.files.xmlsafe import parse_xml

    base = Path(source_path).parent
    out: dict[str, bytes] = {}
    for name, blob in sorted(sources.items()):
        if not name.startswith("model/") or not name.lower().endswith(".urdf"):
            continue
        try:
            root = parse_xml(blob, name)
        except HarnessError:
            continue
        for mesh in root.iter("mesh"):
            uri = str(mesh.get("filename") or "")
            target = _target(uri)
            if target is None or ATTACHMENT_SOURCE_PREFIX + target in out:
                continue
            try:
                path = resolve_uri(uri, base_dir=base, what="mesh")
                out[ATTACHMENT_SOURCE_PREFIX + target] = path.read_bytes()
            except (HarnessError, OSError):
                continue
    return out


def _files(root: object, paths: str) -> set[str]:
    return {str(e.get("filename") or "") for e in root.iterfind(paths)}  # type: ignore[attr-defined]


def visual_only_attachments(sources: Mapping[str, bytes]) -> set[str]:
    """The ``source/...`` attachment names of the files only the visuals of the URDF model
    files among ``sources`` use: meshes referenced by ``<visual>`` elements and by no
    ``<collision>``, and textures."""
    from harness.models.files.xmlsafe import parse_xml

    out: set[str] = set()
    for name, blob in sorted(sources.items()):
        if not name.startswith("model/") or not name.lower().endswith(".urdf"):
            continue
        try:
            root = parse_xml(blob, name)
        except HarnessError:
            continue
        visual = _files(root, ".//visual//mesh") | _files(root, ".//texture")
        for uri in visual - _files(root, ".//collision//mesh"):
            target = _target(uri)
            if target is None:
                continue
            out.add(ATTACHMENT_SOURCE_PREFIX + target)
            if uri.startswith("package://"):
                out.add(f"{ATTACHMENT_SOURCE_PREFIX}package/{target}")
    return out
