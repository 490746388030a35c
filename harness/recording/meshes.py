"""The mesh files a robot's URDF source references, as attachments another machine can use.

The compiled model (``model.mjb``) holds every mesh as MuJoCo decoded it, which is all a
bit-exact replay needs; but rebuilding the robot from its sources (``source/model/...``), on a
machine without the robot's package, needs the mesh files too. :func:`mesh_attachments`
resolves each ``<mesh filename=...>`` of the URDF sources as loading did
(:func:`harness.models.resolve.resolve_uri`: ``ROS_PACKAGE_PATH``, the folders above the
file) and names it where the rebuild looks first (replay writes ``source/`` attachments into
one folder): ``package://pkg/rest`` as ``source/pkg/rest`` (the folder named like the package
next to ``model/``), a relative path as ``source/`` + the path from ``model/``. References that
cannot be resolved here, or only through an explicit package map, absolute paths and
``file://`` URIs are left out (the recording still replays from ``model.mjb``).
"""

from __future__ import annotations

import posixpath
from collections.abc import Mapping
from pathlib import Path

from harness.errors import HarnessError
from harness.recording.layout import ATTACHMENT_SOURCE_PREFIX

__all__ = ["mesh_attachment_name", "mesh_attachments"]

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
    from harness.models.resolve import resolve_uri
    from harness.models.xmlsafe import parse_xml

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
