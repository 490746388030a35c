"""``<include>`` URIs to SDF files: ``model://`` (the Gazebo resource paths), Fuel URIs (the
local Fuel cache, :mod:`harness.models.files.fuel`), ``file://`` and paths; a model folder gives the
newest SDF file of a supported version its ``model.config`` lists."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from harness.errors import ModelError
from harness.models.errors import OutsideReferenceError, ResolveError
from harness.models.files.confine import check_confined
from harness.models.files.fuel import LIGHT_ONLY_MODELS, FuelUri, find_fuel_model, parse_fuel_uri
from harness.models.files.resolve import find_model
from harness.models.files.xmlsafe import read_xml_file
from harness.models.sdf.errors import SdfIncludeError

__all__ = ["SUPPORTED_VERSIONS", "include_file"]

SUPPORTED_VERSIONS: tuple[str, ...] = tuple(f"1.{minor}" for minor in range(4, 12))
"""The SDFormat versions this reader accepts."""


def include_file(
    uri: str,
    source: Path,
    where: str,
    search_paths: Sequence[Path],
    *,
    light_ok: bool = False,
) -> Path | None:
    """The SDF file the ``<include>`` URI ``uri`` in ``source`` names (``where`` prefixes
    errors; ``search_paths`` are searched first for ``model://``), or None for a light-only
    stock model (``sun``) that is nowhere to be found when ``light_ok``."""
    fuel = parse_fuel_uri(uri)
    try:
        if fuel is not None:
            target = find_fuel_model(fuel, uri)
            target = target / fuel.rest if fuel.rest else target
        elif uri.startswith("model://"):
            name, _, rest = uri[len("model://") :].partition("/")
            target = find_model(name, search_paths=search_paths, start=source.parent)
            target = target / rest if rest else target
        elif "://" in uri and not uri.startswith("file://"):
            raise SdfIncludeError(f"{where}: unsupported include URI scheme in {uri!r}")
        else:
            target = Path(uri.removeprefix("file://")).expanduser()
            if not target.is_absolute():
                target = source.parent / target
    except OutsideReferenceError as exc:  # a rebuild from a recording: refused as it is
        raise type(exc)(f"{where}: include {uri!r}: {exc}") from None
    except ResolveError as exc:
        if light_ok and _stock_light(uri, fuel):
            return None
        raise SdfIncludeError(f"{where}: missing include {uri!r}: {exc}") from None
    check_confined(target, uri, context=where, what="include")
    if target.is_dir():
        return _model_config_sdf(target, uri, where)
    if not target.is_file():
        raise SdfIncludeError(f"{where}: missing include {uri!r}: {target} does not exist")
    return target


def _model_config_sdf(folder: Path, uri: str, where: str) -> Path:
    """The SDF file of a model folder: the newest supported version its model.config lists."""
    config = folder / "model.config"
    if not config.is_file():
        fallback = folder / "model.sdf"
        if fallback.is_file():
            return fallback
        raise SdfIncludeError(
            f"{where}: missing include {uri!r}: {folder} has no model.config or model.sdf"
        )
    try:
        root, _ = read_xml_file(config)
    except ModelError as exc:
        raise SdfIncludeError(f"{where}: include {uri!r}: {exc}") from None
    choices: list[tuple[tuple[int, int], str]] = []
    for sdf in root.findall("sdf"):
        text = (sdf.text or "").strip()
        version_text = sdf.get("version", "0.0")
        try:
            major, minor = (int(p) for p in version_text.split(".")[:2])
        except ValueError:
            continue
        if text and version_text in SUPPORTED_VERSIONS:
            choices.append(((major, minor), text))
    if not choices:
        raise SdfIncludeError(
            f"{where}: include {uri!r}: {config} lists no <sdf> file of a supported version"
        )
    target = folder / max(choices)[1]
    if not target.is_file():
        raise SdfIncludeError(f"{where}: missing include {uri!r}: {target} does not exist")
    return target


def _stock_light(uri: str, fuel: FuelUri | None) -> bool:
    """Whether ``uri`` names a stock model that is only a light (``model://sun``, Fuel's
    ``OpenRobotics/Sun``)."""
    if fuel is not None:
        return fuel.owner.lower() == "openrobotics" and fuel.name.lower() in LIGHT_ONLY_MODELS
    name = (
        uri.removeprefix("model://").strip("/").split("/")[0] if uri.startswith("model://") else ""
    )
    return name.lower() in LIGHT_ONLY_MODELS
