"""Resolve the file references of robot descriptions to local paths.

``package://pkg/rest`` (ROS), ``model://name/rest`` (Gazebo / SDFormat), ``file://path`` and
plain paths (absolute, or relative to the referencing file's folder). Nothing is fetched
from the network; a reference that cannot be resolved is a :class:`ResolveError` naming what
was searched.

Package search order: the explicit ``packages`` map, then ``ROS_PACKAGE_PATH``, then the
``share/`` folder of each prefix in ``AMENT_PREFIX_PATH`` (a sourced ROS 2 install works as
is), then the folders above the referencing file (a folder named like the package, a child
folder named like it, or a folder whose ``package.xml`` declares that name). A package is
known by the ``<name>`` its ``package.xml`` declares, as rospack and ament know it: a folder
named like the package counts unless its ``package.xml`` declares another name, and when no
folder is named so, ``ROS_PACKAGE_PATH`` and the share folders are crawled for the
``package.xml`` that declares it (as rospack does: not into a package, a hidden folder or one
holding ``CATKIN_IGNORE``/``COLCON_IGNORE``/``AMENT_IGNORE``; at most
:data:`CRAWL_LIMIT` folders per root). xacro's
``$(find pkg)`` uses the same search (:mod:`harness.models.xacro.expand`). ``model://`` searches the
explicit ``search_paths``, then ``GZ_SIM_RESOURCE_PATH``, ``SDF_PATH``,
``IGN_GAZEBO_RESOURCE_PATH``, ``GAZEBO_MODEL_PATH``, then the folders above the file. A Fuel
URI (``https://fuel.gazebosim.org/1.0/<owner>/models/<name>/<version>/files/<path>``) is read
from the local Fuel cache (:mod:`harness.models.files.fuel`).

``package://`` and ``model://`` references are confined to the folder of the package (model)
they name: a reference whose path leaves that folder (``..``) is refused, and so is one whose
real path (symlinks resolved) lies outside it, except into the same colcon workspace: in a
``colcon build --symlink-install`` tree the files of ``install/<pkg>/share/<pkg>`` are links
into ``src/`` (and ``build/``), and a link from a package under an ``install`` folder colcon
made may lead anywhere inside that workspace (the folder holding ``install``), never out of
it. A package name that is not a plain folder name (``..``, empty) is refused.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from urllib.parse import unquote

from harness.models.errors import OutsideReferenceError, ResolveError, UnknownPackageError
from harness.models.files.confine import check_confined, confinement, inside_confinement
from harness.models.files.fuel import find_fuel_model, parse_fuel_uri
from harness.names import package_problem

__all__ = [
    "CRAWL_LIMIT",
    "MODEL_PATH_VARIABLES",
    "PackageMap",
    "find_model",
    "find_package",
    "owning_package",
    "resolve_uri",
]

PackageMap = Mapping[str, "str | os.PathLike[str]"]
"""Package (or ``model://`` model) name -> folder."""

MODEL_PATH_VARIABLES: tuple[str, ...] = (
    "GZ_SIM_RESOURCE_PATH",
    "SDF_PATH",
    "IGN_GAZEBO_RESOURCE_PATH",
    "GAZEBO_MODEL_PATH",
)


CRAWL_LIMIT = 20_000
"""The most folders one search root's crawl for a ``package.xml`` visits."""
_IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")
_COLCON_INSTALL_MARKERS = (".colcon_install_layout", "COLCON_IGNORE", "local_setup.sh")


def _env_paths(variables: Iterable[str]) -> list[Path]:
    paths: list[Path] = []
    for var in variables:
        paths.extend(Path(p) for p in os.environ.get(var, "").split(os.pathsep) if p)
    return paths


def _ament_shares() -> list[Path]:
    """The ``share/`` folder of every ``AMENT_PREFIX_PATH`` prefix (where ROS 2 installs
    each package's ``share/<package>``)."""
    return [prefix / "share" for prefix in _env_paths(["AMENT_PREFIX_PATH"])]


def _declared_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml`` (None: no readable manifest with a name)."""
    manifest = folder / "package.xml"
    if not manifest.is_file():
        return None
    try:
        text = manifest.read_text(errors="replace")
    except OSError:
        return None
    match = re.search(r"<name>\s*([^<\s]+)\s*</name>", text)
    return match.group(1) if match else None


def _declares_package(folder: Path, name: str) -> bool:
    return _declared_name(folder) == name


def _named(folder: Path, name: str) -> bool:
    """Whether ``folder`` (named ``name``) is package ``name``: a folder without a manifest
    counts by its name (a Gazebo model, an install share folder); one whose ``package.xml``
    declares another name is that other package."""
    if not folder.is_dir():
        return False
    declared = _declared_name(folder)
    return declared is None or declared == name


def _crawl(root: Path, name: str) -> Path | None:
    """The folder under ``root`` whose ``package.xml`` declares ``name``, found as rospack
    crawls (see the module docstring); None when there is none."""
    pending = [root]
    visited = 0
    while pending and visited < CRAWL_LIMIT:
        folder = pending.pop(0)
        visited += 1
        declared = _declared_name(folder)
        if declared is not None:
            if declared == name:
                return folder
            continue  # a package: no packages inside it
        try:
            children = sorted(
                (c for c in folder.iterdir() if c.is_dir() and not c.is_symlink()),
                key=lambda c: c.name,
            )
        except OSError:
            continue
        if any((folder / marker).exists() for marker in _IGNORE_MARKERS) and folder != root:
            continue
        pending.extend(c for c in children if not c.name.startswith("."))
    return None


def _search(
    name: str, roots: Sequence[Path], start: Path | None, *, package: bool = False
) -> Path | None:
    """``package``: a ROS package (known by its ``package.xml``, crawled for), else a Gazebo
    model (known by its folder name)."""
    named = _named if package else (lambda folder, _: folder.is_dir())
    for root in roots:
        if root.name == name and named(root, name):
            return root
        if named(root / name, name):
            return root / name
    crawl = package and confinement() is None
    if crawl:
        for root in roots:
            found = _crawl(root, name)
            if found is not None:
                return found
    if start is not None:
        for folder in (start, *start.parents):
            if not inside_confinement(folder):
                break  # a rebuild from a recording searches its own folder only
            if folder.name == name or _declares_package(folder, name):
                return folder
            if (folder / name).is_dir():
                return folder / name
    return None


def _tried(
    explicit: Mapping[str, object],
    roots: Sequence[Path],
    start: Path | None,
    ament: Sequence[Path] = (),
) -> str:
    parts = [f"packages map {sorted(explicit)}" if explicit else "no packages map"]
    parts.append(f"search paths {[str(r) for r in roots]}" if roots else "no search paths set")
    if ament:
        parts.append(f"AMENT_PREFIX_PATH share folders {[str(r) for r in ament]}")
    if start is not None:
        parts.append(f"the folders above {start}")
    return "; ".join(parts)


def find_package(
    name: str, *, packages: PackageMap | None = None, start: str | Path | None = None
) -> Path:
    """The folder of ROS package ``name`` (see the module docstring for the search order)."""
    explicit = dict(packages or {})
    if name in explicit:
        return Path(explicit[name])
    confined = confinement() is not None  # only the recording's folder: no environment
    roots = [] if confined else _env_paths(["ROS_PACKAGE_PATH"])
    ament = [] if confined else _ament_shares()
    begin = Path(start).resolve() if start is not None else None
    found = _search(name, [*roots, *ament], begin, package=True)
    if found is None and confined:
        raise OutsideReferenceError(f"package {name!r} is not among the recording's attachments")
    if found is None:
        raise UnknownPackageError(
            f"unknown package {name!r} (tried {_tried(explicit, roots, begin, ament)})"
        )
    return found


def owning_package(path: str | Path) -> tuple[str, Path] | None:
    """The ROS package a file lies in: the name its nearest ``package.xml`` declares and that
    folder (None when no folder above the file has a ``package.xml`` with a name)."""
    for folder in Path(path).resolve().parents:
        manifest = folder / "package.xml"
        if not manifest.is_file():
            continue
        try:
            text = manifest.read_text(errors="replace")
        except OSError:
            return None
        match = re.search(r"<name>\s*([^<\s]+)\s*</name>", text)
        return (match.group(1), folder) if match else None
    return None


def find_model(
    name: str, *, search_paths: Sequence[str | Path] | None = None, start: str | Path | None = None
) -> Path:
    """The folder of Gazebo model ``name`` for ``model://name/...`` URIs."""
    roots = [Path(p) for p in search_paths or ()]
    if confinement() is None:
        roots += _env_paths(MODEL_PATH_VARIABLES)
    else:  # only the recording's folder
        roots = [r for r in roots if inside_confinement(r)]
    begin = Path(start).resolve() if start is not None else None
    found = _search(name, roots, begin)
    if found is None and confinement() is not None:
        raise OutsideReferenceError(f"model {name!r} is not among the recording's attachments")
    if found is None:
        raise UnknownPackageError(f"unknown model {name!r} (tried {_tried({}, roots, begin)})")
    return found


def _check_name(name: str, kind: str) -> None:
    if not name:
        raise ResolveError(f"empty {kind} name")
    problem = package_problem(name)
    if problem is not None:
        raise ResolveError(f"invalid {kind} name {name!r}: it {problem}")


def _workspace(root: Path) -> Path | None:
    """The colcon workspace ``root`` (a package folder, links not followed) was installed
    into: the folder holding the ``install`` folder above it that colcon made (None when
    there is none)."""
    for folder in root.absolute().parents:
        if (
            folder.name == "install"
            and folder.parent != folder.parent.parent  # never the whole filesystem
            and any((folder / marker).exists() for marker in _COLCON_INSTALL_MARKERS)
        ):
            return folder.parent
    return None


def _confined(root: Path, rest: str, kind: str, name: str) -> Path:
    """``root / rest``, refusing a path that leaves ``root`` (``..``) and one whose real path
    leaves ``root``'s real path, unless it stays inside the colcon workspace ``root`` was
    installed into (a ``--symlink-install`` tree)."""
    path = root / rest
    real_root = root.resolve()
    lexical = Path(os.path.normpath(root.absolute() / rest))
    real = path.resolve()
    if lexical.is_relative_to(root.absolute()) and real.is_relative_to(real_root):
        return path
    # never while a rebuild from a recording is confined (its files are plain files anyway)
    widen = lexical.is_relative_to(root.absolute()) and confinement() is None
    workspace = _workspace(root) if widen else None
    if workspace is not None and real.is_relative_to(workspace.resolve()):
        return path
    within = f" or its workspace {str(workspace.resolve())!r}" if workspace is not None else ""
    raise ResolveError(
        f"reference escapes {kind} {name!r} (folder {str(real_root)!r}{within}, "
        f"the reference leads to {str(real)!r})"
    )


def resolve_uri(
    uri: str,
    *,
    base_dir: str | Path,
    packages: PackageMap | None = None,
    search_paths: Sequence[str | Path] | None = None,
    context: str = "",
    what: str = "file",
) -> Path:
    """Resolve ``uri`` to an existing local file.

    ``base_dir``: the folder of the referencing file (relative paths and the upward search
    start there); ``packages``: explicit package map for ``package://``; ``search_paths``:
    extra roots for ``model://``; ``context`` prefixes error messages (file and element);
    ``what`` names the kind of file in them ("mesh", "include", ...).
    """
    prefix = f"{context}: " if context else ""
    base = Path(base_dir)
    try:
        if uri.startswith("package://"):
            # package:///pkg/x (seen in real files) means package://pkg/x
            name, _, rest = uri[len("package://") :].lstrip("/").partition("/")
            _check_name(name, "package")
            root = find_package(name, packages=packages, start=base)
            check_confined(root / unquote(rest), uri, what=what)
            path = _confined(root, unquote(rest), "package", name)
        elif uri.startswith("model://"):
            name, _, rest = uri[len("model://") :].lstrip("/").partition("/")
            _check_name(name, "model")
            if packages and name in packages:
                root = Path(packages[name])
            else:
                root = find_model(name, search_paths=search_paths, start=base)
            check_confined(root / unquote(rest), uri, what=what)
            path = _confined(root, unquote(rest), "model", name)
        elif (fuel := parse_fuel_uri(uri)) is not None:
            root = find_fuel_model(fuel, uri)
            check_confined(root / fuel.rest, uri, what=what)
            path = _confined(root, fuel.rest, "Fuel model", f"{fuel.owner}/{fuel.name}")
        elif uri.startswith("file://"):
            path = Path(unquote(uri[len("file://") :]))
            if not path.is_absolute():
                path = base / path
        elif "://" in uri:
            raise ResolveError(f"unsupported URI scheme in {uri!r}")
        else:
            path = Path(uri).expanduser()
            if not path.is_absolute():
                path = base / path
    except OutsideReferenceError as exc:  # confined (a rebuild from a recording)
        suffix = "" if repr(uri) in str(exc) else f" in {uri!r}"
        raise OutsideReferenceError(f"{prefix}{exc}{suffix}") from None
    except ResolveError as exc:
        raise type(exc)(f"{prefix}{exc} in {uri!r}") from None
    check_confined(path, uri, context=context, what=what)
    if not path.is_file():
        raise ResolveError(f"{prefix}{what} not found: {str(path)!r} (from {uri!r})")
    return path
