"""Gazebo Fuel URIs resolved offline, from the local Fuel cache, as gz resolves them.

A Fuel model URI is ``https://fuel.gazebosim.org/1.0/<owner>/models/<name>[/<version>]``
(``<version>`` a number or ``tip``; the older host ``fuel.ignitionrobotics.org`` too), and a
file of a model ``.../models/<name>/<version>/files/<path>``. gz keeps what it downloaded in
``<cache>/<host>/<owner>/models/<name>/<version>/`` with owner and name in lower case; the
caches searched are ``GZ_FUEL_CACHE_PATH`` (and the older ``IGN_FUEL_CACHE_PATH``), then
``~/.gz/fuel`` and ``~/.ignition/fuel``, under the URI's host first and then the other Fuel
host (the same server under two names). Without a version the highest cached one is used.

Nothing is ever downloaded. OpenRobotics' stock ``Ground Plane`` and ``Sun`` fall back to the
harness's own copies (``harness/models/data/gazebo_models``) when no cache has them; any other
model that is not cached is a :class:`FuelModelMissingError` naming the URI and every folder
searched. While loading is confined to a recording's folder (see
:mod:`harness.models.files.confine`) no cache is read: only the stock copies.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import NamedTuple
from urllib.parse import unquote, urlsplit

from harness.models.bundled import DATA
from harness.models.errors import OutsideReferenceError, ResolveError
from harness.models.files.confine import confinement

__all__ = [
    "FUEL_CACHE_VARIABLES",
    "FUEL_HOSTS",
    "LIGHT_ONLY_MODELS",
    "RECORDED_FUEL_CACHE",
    "STOCK_FOLDER",
    "STOCK_MODELS",
    "FuelModelMissingError",
    "FuelUri",
    "find_fuel_model",
    "fuel_cache_roots",
    "parse_fuel_uri",
]

FUEL_HOSTS: tuple[str, ...] = ("fuel.gazebosim.org", "fuel.ignitionrobotics.org")
"""The Fuel server's host names (the second is its older name)."""
FUEL_CACHE_VARIABLES: tuple[str, ...] = ("GZ_FUEL_CACHE_PATH", "IGN_FUEL_CACHE_PATH")
"""Environment variables naming a Fuel cache folder, searched before the default ones."""
STOCK_FOLDER = DATA / "gazebo_models"
"""The harness's copies of Gazebo's stock models."""
STOCK_MODELS: Mapping[tuple[str, str], str] = MappingProxyType(
    {("openrobotics", "ground plane"): "ground_plane", ("openrobotics", "sun"): "sun"}
)
"""(owner, name) in lower case -> the folder of the harness's copy in :data:`STOCK_FOLDER`."""
LIGHT_ONLY_MODELS: frozenset[str] = frozenset({"sun"})
"""Stock model names (lower case) that hold only a light: an include of one is skipped even
when no copy of it is found (a light carries no physics)."""


class FuelModelMissingError(ResolveError):
    """A Fuel model (or a version of it) is in no local Fuel cache."""


class FuelUri(NamedTuple):
    """A parsed Fuel URI: ``host`` (lower case), ``owner`` and ``name`` as written (URL
    escapes decoded), ``version`` (None: the highest, as for ``tip``) and ``rest``: the path
    below ``files/`` for a file of the model (``""`` for the model itself)."""

    host: str
    owner: str
    name: str
    version: int | None
    rest: str


def parse_fuel_uri(uri: str) -> FuelUri | None:
    """The :class:`FuelUri` of ``uri``, or None when it is not a Fuel model URI."""
    try:
        parts = urlsplit(uri.strip())
    except ValueError:
        return None
    host = (parts.hostname or "").lower()
    if parts.scheme.lower() not in ("http", "https") or host not in FUEL_HOSTS:
        return None
    segments = [unquote(s) for s in parts.path.split("/") if s]
    # 1.0 / <owner> / models / <name> [/ <version>] [/ files / <path>]
    if len(segments) < 4 or segments[2].lower() != "models":
        return None
    owner, name, tail = segments[1], segments[3], segments[4:]
    version: int | None = None
    if tail and tail[0].lower() != "files":
        if tail[0].isdigit():
            version = int(tail[0])
        elif tail[0].lower() != "tip":
            return None
        tail = tail[1:]
    rest = ""
    if tail:
        if tail[0].lower() != "files":
            return None
        rest = "/".join(tail[1:])
    return FuelUri(host, owner, name, version, rest)


RECORDED_FUEL_CACHE = "scene/fuel"
"""Where a recording lays out the Fuel models a world read (:mod:`harness.models.sdf.worldfile`):
a rebuild's only Fuel cache, inside its folder."""


def fuel_cache_roots() -> list[Path]:
    """The Fuel cache folders searched, in order (see the module docstring); a rebuild from a
    recording (loading confined to its folder) searches only :data:`RECORDED_FUEL_CACHE`."""
    confined = confinement()
    if confined is not None:
        return [confined / RECORDED_FUEL_CACHE]
    roots: list[Path] = []
    for variable in FUEL_CACHE_VARIABLES:
        roots.extend(Path(p) for p in os.environ.get(variable, "").split(os.pathsep) if p)
    home = Path.home()
    roots += [home / ".gz" / "fuel", home / ".ignition" / "fuel"]
    unique: list[Path] = []
    for root in roots:
        if root not in unique:
            unique.append(root)
    return unique


def _versions(folder: Path) -> list[int]:
    if not folder.is_dir():
        return []
    return sorted(int(c.name) for c in folder.iterdir() if c.name.isdigit() and c.is_dir())


def find_fuel_model(fuel: FuelUri, uri: str) -> Path:
    """The folder of the model ``fuel`` names (its cached version: the one asked for, else
    the highest), or the harness's stock copy; :class:`FuelModelMissingError` naming ``uri``
    and every folder searched when neither exists."""
    stock = STOCK_MODELS.get((fuel.owner.lower(), fuel.name.lower()))
    searched: list[str] = []
    hosts = [fuel.host, *(h for h in FUEL_HOSTS if h != fuel.host)]
    for root in fuel_cache_roots():
        for host in hosts:
            folder = root / host / fuel.owner.lower() / "models" / fuel.name.lower()
            searched.append(str(folder))
            versions = _versions(folder)
            if fuel.version is not None and fuel.version in versions:
                return folder / str(fuel.version)
            if fuel.version is None and versions:
                return folder / str(versions[-1])
    if stock is not None:
        return STOCK_FOLDER / stock
    if confinement() is not None:
        raise OutsideReferenceError(f"Fuel model {uri!r} is not among the recording's attachments")
    wanted = f"version {fuel.version} of " if fuel.version is not None else ""
    raise FuelModelMissingError(
        f"{wanted}Fuel model {fuel.owner}/{fuel.name} is in no local Fuel cache (searched "
        f"{', '.join(searched)}); Fuel is never downloaded: fetch it once with "
        f"`gz fuel download -u '{uri}'` or point GZ_FUEL_CACHE_PATH at a cache that has it"
    )
