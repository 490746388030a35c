"""xacro robot descriptions, expanded by the ROS ``xacro`` package itself (PyPI ``xacro``, the
implementation ROS ships; one pass, as ``ros2 run xacro xacro`` does) into a URDF that stays
portable.

- Arguments are spelled as users spell them: ``NAME:=VALUE`` (:func:`parse_robot_arg`) on the
  CLI, ``robot_args={...}`` in Python, the marker and scenario files. An argument used
  (``$(arg name)``) that is neither given nor declared with a default is one
  :class:`~harness.models.errors.XacroError` naming it and the file.
- ``$(find pkg)`` uses the package search of ``package://``
  (:func:`harness.models.files.resolve.find_package`: the ``packages`` map, ``ROS_PACKAGE_PATH``,
  ``AMENT_PREFIX_PATH``, the folders above the file); ``$(arg)``, ``$(env)``, ``$(eval)``,
  includes, macros and ``xacro.load_yaml`` work as in ROS.
- The expanded URDF keeps ``package://`` references: a path the expansion made absolute
  (``file://$(find pkg)/...`` in a mesh, ``$(find pkg)/config/x.yaml`` as an element's text)
  inside a package it found, or a mesh path relative to the entry file that leads into one, is
  written as ``package://pkg/...``, so the text means the same on every machine.
- :attr:`Expansion.sources` holds every file the expansion read (``xacro/<pkg>/<path>``) and
  every existing file its ``package://`` references name (``package/<pkg>/<path>``: meshes,
  controller files): with the expanded URDF they rebuild the robot with neither the package
  nor xacro installed.
- Expansions are cached per process by content: the entry file, every file it read, the
  arguments, the packages found and the environment variables the files name; a test suite
  that loads one robot in 200 tests expands it once.

- Expansion is bounded while it runs (:mod:`harness.models.xacro.meter`): elements, expressions,
  text, DOM work, nesting and time are counted as xacro produces them, the first over its limit
  (:class:`~harness.models.files.limits.XacroLimits`, ``HARNESS_MAX_XACRO_*``) is one
  :class:`~harness.models.files.limits.ModelLimitError` naming the file; a 2 KB file of macros
  that double at each of 22 levels is refused at 50,000 elements, in 2 to 3 s of CPU.

xacro keeps its state in module globals, so expansions run one at a time (a lock).
"""

from __future__ import annotations

import gc
import hashlib
import os
import re
import threading
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any
from urllib.parse import unquote

from harness.errors import HarnessError
from harness.models.description import XacroOrigin
from harness.models.errors import ResolveError, XacroError
from harness.models.files.limits import xacro_limits
from harness.models.files.resolve import PackageMap, find_package, owning_package, resolve_uri
from harness.models.files.xmlsafe import MAX_XML_BYTES, check_size, parse_xml
from harness.models.xacro.meter import XacroMeter, metered

__all__ = [
    "XACRO_SUFFIX",
    "Expansion",
    "RobotArgs",
    "UnusedRobotArgWarning",
    "XacroOrigin",
    "clear_cache",
    "expand_xacro",
    "is_xacro",
    "normalize_args",
    "parse_robot_arg",
]

XACRO_SUFFIX = ".xacro"
RobotArgs = Mapping[str, "str | int | float | bool"]
"""xacro arguments: name -> value (numbers and booleans are written as xacro reads them)."""

_XACRO_NAMESPACE = re.compile(rb"xmlns:xacro\s*=\s*[\"'][^\"']*xacro", re.I)
_ARG_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-.]*")
_COMMENT = re.compile(rb"<!--.*?-->", re.S)
_ENV_USE = re.compile(r"\$\((?:env|optenv)\s+([A-Za-z_][A-Za-z0-9_]*)")
_LOCK = threading.Lock()


class UnusedRobotArgWarning(UserWarning):
    """A robot argument was given that none of the files the expansion read mentions (xacro
    ignores it: often a misspelled name)."""


@dataclass(frozen=True)
class Expansion:
    """An expanded xacro file: ``urdf`` (UTF-8 text with ``package://`` references kept),
    ``origin``, ``sources`` (attachment name -> bytes: ``xacro/...`` the files read,
    ``package/<pkg>/<path>`` the meshes named) and ``packages`` (every package found)."""

    path: Path
    urdf: bytes
    origin: XacroOrigin
    sources: Mapping[str, bytes]
    packages: Mapping[str, Path]

    @property
    def urdf_name(self) -> str:
        """The expanded file's name: the entry's without ``.xacro`` (``.urdf`` added when
        nothing is left of a suffix)."""
        name = self.path.name
        stem = name[: -len(XACRO_SUFFIX)] if name.endswith(XACRO_SUFFIX) else name
        return stem if stem.endswith(".urdf") else f"{Path(stem).stem or 'robot'}.urdf"


def is_xacro(path: str | Path) -> bool:
    """A ``.xacro`` file, or an XML file whose ``<robot>`` root declares the xacro namespace
    and uses it outside comments (a ``<xacro:...>`` element, ``${...}`` or ``$(...)``): URDFs
    that xacro wrote keep the declaration and need no second expansion."""
    path = Path(path)
    if path.suffix.lower() == XACRO_SUFFIX:
        return True
    try:
        with path.open("rb") as handle:
            head = handle.read(8192)
            start = head.find(b"<robot")
            end = head.find(b">", start)
            if start < 0 or not _XACRO_NAMESPACE.search(head[start : end + 1]):
                return False
            data = head + handle.read(MAX_XML_BYTES)
    except OSError:
        return False
    data = _COMMENT.sub(b"", data)  # xacro leaves comments alone
    return b"<xacro:" in data or b"${" in data or b"$(" in data


def parse_robot_arg(text: str) -> tuple[str, str]:
    """``"NAME:=VALUE"`` -> ``(NAME, VALUE)``; anything else is a :class:`XacroError`."""
    name, sep, value = text.partition(":=")
    if not sep or not _ARG_NAME.fullmatch(name):
        raise XacroError(f"robot argument {text!r} is not NAME:=VALUE (e.g. ur_type:=ur5e)")
    return name, value


def normalize_args(
    args: RobotArgs | Iterable[str] | None, where: str = "robot_args"
) -> dict[str, str]:
    """xacro arguments as strings: a mapping, or ``NAME:=VALUE`` items; booleans become
    ``true``/``false``, numbers their ``repr``."""
    if args is None:
        return {}
    if isinstance(args, Mapping):
        items = list(args.items())
    elif isinstance(args, str):
        raise XacroError(f"{where}: give a mapping or a list of NAME:=VALUE, not {args!r}")
    else:
        items = [parse_robot_arg(str(item)) for item in args]
    out: dict[str, str] = {}
    for name, value in items:
        if not isinstance(name, str) or not _ARG_NAME.fullmatch(name):
            raise XacroError(f"{where}: argument name {name!r} is not a xacro argument name")
        if isinstance(value, bool):
            out[name] = "true" if value else "false"
        elif isinstance(value, int | float | str):
            out[name] = str(value) if not isinstance(value, float) else repr(value)
        else:
            raise XacroError(
                f"{where}: argument {name!r} is {type(value).__name__} {value!r} "
                "(expected a string, number or boolean)"
            )
    return out


# ------------------------------------------------------------------------------- the cache

_Key = tuple[str, str, tuple[tuple[str, str], ...], tuple[tuple[str, str], ...]]
_CACHE: dict[_Key, list[tuple[tuple[tuple[str, str], ...], Expansion]]] = {}


def clear_cache() -> None:
    """Forget every cached expansion of this process."""
    with _LOCK:
        _CACHE.clear()


def _digest(path: Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return "-"


def _fingerprint(
    files: Sequence[Path],
    found: Mapping[str, Path],
    env: Iterable[str],
    packages: PackageMap | None,
    start: Path,
) -> tuple[tuple[str, str], ...]:
    """What the expansion depended on: file contents, where each package is, env values."""
    out = [(f"file:{p}", _digest(p)) for p in files]
    for name in sorted(found):
        try:
            where = str(find_package(name, packages=packages, start=start).resolve())
        except ResolveError:
            where = "-"
        out.append((f"package:{name}", where))
    out += [(f"env:{name}", os.environ.get(name, "\0")) for name in sorted(set(env))]
    return tuple(out)


# ----------------------------------------------------------------------------- expansion


def _cause(exc: BaseException) -> BaseException:
    """The innermost exception xacro wrapped (``XacroException.exc`` chains)."""
    seen = {id(exc)}  # as deep as the properties that resolve each other (a cycle ends)
    while getattr(exc, "exc", None) is not None and id(exc.exc) not in seen:  # type: ignore[attr-defined]
        exc = exc.exc  # type: ignore[attr-defined]
        seen.add(id(exc))
    return exc


def _current_file(xacro_module: Any, fallback: Path) -> str:
    stack = [f for f in getattr(xacro_module, "filestack", None) or [] if f]
    return str(stack[-1]) if stack else str(fallback)


def _missing_arg(exc: Exception) -> str | None:
    """The argument name of an undefined ``$(arg name)`` (None for any other error)."""
    from xacro.substitution_args import ArgException

    cause = _cause(exc)
    return str(cause) if isinstance(cause, ArgException) else None


def _error(
    exc: Exception, where: str, args: Mapping[str, str], missing: Sequence[str]
) -> HarnessError:
    from xml.parsers.expat import ExpatError

    cause = _cause(exc)
    if isinstance(cause, HarnessError):
        return type(cause)(f"{where}: {cause}")
    if missing:
        given = ", ".join(sorted(args)) or "none"
        names = ", ".join(repr(m) for m in missing)
        plural = "s" if len(missing) > 1 else ""
        options = " ".join(f"--robot-arg {m}:=VALUE" for m in missing)
        return XacroError(
            f"{where}: undefined argument{plural} {names} (used, not declared with a default "
            f"and not given; given: {given}; pass {options} or robot_args={{{missing[0]!r}: ...}})"
        )
    if isinstance(exc, ExpatError):
        return XacroError(f"{where}:{exc.lineno}: malformed XML: {exc}")
    if isinstance(cause, RecursionError):
        return XacroError(f"{where}: xacro: elements or macro calls nested too deep for Python")
    text = " ".join(str(exc).split())
    return XacroError(f"{where}: xacro: {text or type(exc).__name__}")


@contextmanager
def _c_yaml(xacro_module: Any) -> Iterator[None]:
    """While xacro runs, ``yaml.safe_load`` (what ``xacro.load_yaml`` calls) parses with
    libyaml's C parser (same documents, same values, 30x faster than the pure-Python one that
    took a third of a description package's expansion) and xacro's unit tags."""
    import yaml  # type: ignore[import-untyped,unused-ignore]

    base = getattr(yaml, "CSafeLoader", None)
    if base is None:
        yield
        return
    global _YAML_LOADER
    if _YAML_LOADER is None:
        loader: Any = type("XacroCSafeLoader", (base,), {})
        for unit in xacro_module.ConstructUnits:
            loader.add_constructor(unit.value.tag, unit.constructor)
        _YAML_LOADER = loader
    chosen = _YAML_LOADER
    previous = yaml.safe_load

    def safe_load(stream: Any) -> Any:
        return yaml.load(stream, Loader=chosen)

    yaml.safe_load = safe_load
    try:
        yield
    finally:
        yaml.safe_load = previous


_YAML_LOADER: Any = None


@contextmanager
def _no_gc() -> Iterator[None]:
    """No cyclic garbage collection while xacro builds its DOM: its thousands of nodes set
    off full collections of everything the process holds (MuJoCo, numpy), a third of a cold
    expansion; reference counting still frees what is dropped."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


_MAX_MISSING = 20  # undefined arguments looked for before reporting them


def _run_xacro(
    path: Path, args: Mapping[str, str], packages: PackageMap | None
) -> tuple[str, list[Path], dict[str, Path]]:
    """Expand under the lock: (URDF text, files read after the entry, packages found).

    An undefined ``$(arg)`` is looked for again with that argument set to a placeholder, so
    the error names every argument the user must give (up to the first other error). One
    meter counts every attempt against the limits."""
    import xacro
    from xacro import substitution_args

    found: dict[str, Path] = {}

    def find(name: str) -> str:
        folder = find_package(name, packages=packages, start=path.parent)
        found[name] = folder
        return str(folder.resolve())

    # $(find) is xacro's one hook into ROS (ament_index_python): ours searches like package://
    previous = substitution_args._eval_find
    substitution_args._eval_find = find
    missing: list[str] = []
    first: tuple[Exception, str] | None = None
    meter = XacroMeter(xacro_limits())
    try:
        while True:
            xacro.all_includes = []
            try:
                with _c_yaml(xacro), _no_gc(), metered(xacro, meter):
                    doc = xacro.process_file(
                        str(path), mappings={**args, **dict.fromkeys(missing, "0")}
                    )
                    text = str(doc.toxml())
            except Exception as exc:
                name = _missing_arg(exc)
                if first is None:
                    first = (exc, _current_file(xacro, path))
                if name is None or name in missing or len(missing) >= _MAX_MISSING:
                    break
                missing.append(name)
                continue
            break
        if first is not None:
            raise _error(first[0], first[1], args, missing) from None
    finally:
        substitution_args._eval_find = previous
        read = [Path(p) for p in xacro.all_includes]
        xacro.all_includes = []
        xacro.init_stacks(None)
    files: list[Path] = []
    for item in read:
        resolved = item.resolve()
        if resolved not in files and resolved != path.resolve():
            files.append(resolved)
    return text, files, found


def _packages_of(path: Path, found: Mapping[str, Path]) -> dict[str, Path]:
    folders = {name: folder.resolve() for name, folder in found.items()}
    own = owning_package(path)
    if own is not None:
        folders.setdefault(own[0], own[1].resolve())
    return folders


def _in_package(path: Path, folders: Mapping[str, Path]) -> tuple[str, str] | None:
    """``(package, path inside it)`` for a file inside one of ``folders`` (deepest wins)."""
    best: tuple[str, str] | None = None
    depth = -1
    for name, folder in folders.items():
        if path.is_relative_to(folder) and len(folder.parts) > depth:
            best, depth = (name, path.relative_to(folder).as_posix()), len(folder.parts)
    return best


def _package_uri(value: str, folders: Mapping[str, Path], base: Path | None) -> str | None:
    """``package://pkg/path`` for an absolute path (or ``file://`` URI) inside a known
    package, or a relative one (from ``base``, the entry file's folder) that leads into one;
    else None."""
    plain = unquote(value[len("file://") :]) if value.startswith("file://") else value
    if "://" in plain or not plain:
        return None
    if not os.path.isabs(plain):
        if base is None:
            return None
        plain = str(base / plain)
    inside = _in_package(Path(os.path.normpath(plain)), folders)
    return None if inside is None else f"package://{inside[0]}/{inside[1]}"


def _portable(urdf: str, entry: Path, folders: Mapping[str, Path]) -> tuple[bytes, list[str]]:
    """The URDF with paths into a known package written as ``package://`` (file references,
    absolute or relative to the entry file, and text that is an absolute path, e.g. a
    controllers YAML given through ``$(find pkg)``); returns the text and every
    ``package://`` reference in it."""
    root = parse_xml(urdf.encode("utf-8"), str(entry))
    base = entry.resolve().parent
    references: list[str] = []
    for element in root.iter():
        uri = element.get("filename")
        if uri is not None:
            uri = _package_uri(uri, folders, base) or uri
            element.set("filename", uri)
        text = (element.text or "").strip()
        if uri is None and text and len(element) == 0:
            uri = _package_uri(text, folders, None)
            if uri is not None:
                element.text = uri
        if uri is not None and uri.startswith("package://") and uri not in references:
            references.append(uri)
    return _text(root), references


def _text(root: Any) -> bytes:
    """UTF-8 XML text of an lxml element, with a declaration."""
    from lxml import etree  # type: ignore[import-untyped,unused-ignore]

    data: bytes = etree.tostring(root, xml_declaration=True, encoding="utf-8", pretty_print=True)
    return data


def _source_key(path: Path, entry: Path, folders: Mapping[str, Path]) -> str:
    inside = _in_package(path, folders)
    if inside is not None:
        return f"xacro/{inside[0]}/{inside[1]}"
    base = entry.resolve().parent
    if path.is_relative_to(base):
        return f"xacro/{path.relative_to(base).as_posix()}"
    return f"xacro/{path.name}"


def _mesh_sources(
    references: Sequence[str], entry: Path, packages: PackageMap | None
) -> tuple[dict[str, bytes], list[Path]]:
    """``package/<pkg>/<path>`` -> bytes of every referenced file that exists (a reference
    to a missing file is left to the loader: visual meshes of a trimmed package may be
    absent and unused)."""
    out: dict[str, bytes] = {}
    paths: list[Path] = []
    for uri in references:
        try:
            path = resolve_uri(uri, base_dir=entry.parent, packages=packages)
        except ResolveError:
            continue
        name, _, rest = uri[len("package://") :].lstrip("/").partition("/")
        try:
            out[f"package/{name}/{unquote(rest)}"] = path.read_bytes()
        except OSError:
            continue
        paths.append(path.resolve())
    return out, paths


def expand_xacro(
    path: str | Path,
    args: RobotArgs | Iterable[str] | None = None,
    *,
    packages: PackageMap | None = None,
    reference: str | None = None,
) -> Expansion:
    """Expand the xacro file at ``path`` with ``args`` (see the module docstring).

    ``packages``: package name -> folder, searched first by ``$(find)`` and ``package://``;
    ``reference``: how the user named the file (``package://pkg/...``), kept in the origin.
    Errors: :class:`~harness.models.errors.XacroError` (syntax, undefined argument, failing
    expression or include) and :class:`~harness.models.errors.UnknownPackageError`, each
    naming the file.
    """
    entry = Path(path)
    check_size(entry)
    given = normalize_args(args)
    key: _Key = (
        str(entry.resolve()),
        reference or str(path),
        tuple(sorted(given.items())),
        tuple(sorted((str(k), str(Path(v).resolve())) for k, v in (packages or {}).items())),
    )
    with _LOCK:
        for fingerprint, cached in _CACHE.get(key, []):
            files = [Path(n.removeprefix("file:")) for n, _ in fingerprint if n.startswith("file:")]
            env = [n.removeprefix("env:") for n, _ in fingerprint if n.startswith("env:")]
            found = {
                name.removeprefix("package:"): Path(value)
                for name, value in fingerprint
                if name.startswith("package:")
            }
            if _fingerprint(files, found, env, packages, entry.parent) == fingerprint:
                return cached
        text, read, found = _run_xacro(entry, given, packages)
    folders = _packages_of(entry, found)
    urdf, references = _portable(text, entry, folders)
    sources: dict[str, bytes] = {}
    for file in (entry.resolve(), *read):
        try:
            sources[_source_key(file, entry, folders)] = file.read_bytes()
        except OSError:
            continue
    keys = tuple(sources)
    meshes, mesh_paths = _mesh_sources(references, entry, packages)
    sources.update(meshes)
    origin = XacroOrigin(reference or str(path), MappingProxyType(dict(given)), keys)
    expansion = Expansion(
        path=entry,
        urdf=urdf,
        origin=origin,
        sources=MappingProxyType(sources),
        packages=MappingProxyType(dict(folders)),
    )
    env_names: list[str] = []
    texts = [sources[k].decode("utf-8", errors="replace") for k in keys]
    for text in texts:
        env_names += _ENV_USE.findall(text)
    for name in given:
        mention = re.compile(rf"(?<![\w.-]){re.escape(name)}(?![\w.-])")
        if not any(mention.search(text) for text in texts):
            warnings.warn(
                f"{entry}: robot argument {name!r} is mentioned by none of the {len(texts)} "
                "files the expansion read (xacro ignores it; misspelled?)",
                UnusedRobotArgWarning,
                stacklevel=2,
            )
    env_names += ["ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"]
    fingerprint = _fingerprint(
        [entry.resolve(), *read, *mesh_paths], found, env_names, packages, entry.parent
    )
    with _LOCK:
        _CACHE.setdefault(key, []).append((fingerprint, expansion))
    return expansion
