"""The lights of an SDF world as Gazebo (gz-sim) lights a camera's view, in MuJoCo's terms.

A world's ``<light>`` elements and its light-only includes (Gazebo's stock ``sun``: the
harness's copy when the world's is nowhere to be found) become MuJoCo lights fixed in the
world: ``directional`` (its ``<direction>`` turned by its ``<pose>``), ``point`` (at its pose;
a spot light with a 180 degree cutoff, which MuJoCo's OpenGL renderer draws as a point light)
and ``spot`` (both; MuJoCo's cutoff is half the ``<outer_angle>`` cone, its exponent the
``<falloff>``), with ``<diffuse>`` and ``<specular>`` scaled by ``<intensity>``, point and spot
lights attenuated by ``<attenuation>`` (``constant``, ``linear``, ``quadratic``; ``range`` is
MuJoCo's ``range``, which its OpenGL renderer does not cut at). A light with
``<light_on>false`` is left out. The scene's ambient light (``<scene><ambient>``, SDF's
default 0.4 grey when not written) is MuJoCo's headlight, as ambient only (no diffuse or
specular part that would follow the camera): so a world with no light at all is lit by that
ambient light alone, as gz-sim lights it; ``<scene><background>`` (0.7 grey when not
written) fills a camera's pixels where nothing is drawn (:data:`BACKGROUND_NUMERIC`).
MuJoCo lights per vertex, not per pixel: with a
point or spot light, box faces are drawn as :data:`NUMQUADS` squared quads so the light
falls off across a wall (a mesh is lit at its own vertices). Shadows are not drawn (cameras
render with MuJoCo's shadows off); a light inside a ``<model>`` or ``<link>`` is not read.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import mujoco
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.description import Pose
from harness.models.files.xmlsafe import describe, read_xml_file
from harness.models.sdf.document import _parse_pose
from harness.models.sdf.errors import SdfIncludeError, SdfSyntaxError
from harness.models.sdf.includes import SUPPORTED_VERSIONS, include_file

__all__ = [
    "BACKGROUND_NUMERIC",
    "SCENE_AMBIENT",
    "SCENE_BACKGROUND",
    "Lighting",
    "WorldLight",
    "apply_lighting",
    "world_lighting",
]

Vec3 = tuple[float, float, float]
LightKind = Literal["directional", "point", "spot"]

SCENE_AMBIENT: Vec3 = (0.4, 0.4, 0.4)
"""SDF's default ``<scene><ambient>``."""
SCENE_BACKGROUND: Vec3 = (0.7, 0.7, 0.7)
"""SDF's default ``<scene><background>``."""
BACKGROUND_NUMERIC = "harness:background"
"""The model numeric (r, g, b) :mod:`harness.sensors.render` fills a camera's empty pixels with."""
NUMQUADS = 16
"""Quads per box face side when a world has point or spot lights (MuJoCo's default: 4)."""


@dataclass(frozen=True)
class WorldLight:
    """One light, fixed in the world frame (MuJoCo's units: ``cutoff`` in degrees)."""

    name: str
    kind: LightKind
    pos: Vec3
    dir: Vec3
    diffuse: Vec3
    specular: Vec3
    attenuation: Vec3 = (1.0, 0.0, 0.0)
    range: float = 10.0
    cutoff: float = 45.0
    exponent: float = 0.0


@dataclass(frozen=True)
class Lighting:
    """A world's ``ambient`` light, its ``lights`` and its ``background`` colour."""

    ambient: Vec3 = SCENE_AMBIENT
    lights: tuple[WorldLight, ...] = ()
    background: Vec3 = SCENE_BACKGROUND


def _numbers(element: etree._Element | None, count: int, where: str) -> tuple[float, ...] | None:
    if element is None or not (element.text or "").split():
        return None
    try:
        values = tuple(float(v) for v in (element.text or "").split())
    except ValueError:
        values = ()
    if len(values) < count or not all(math.isfinite(v) for v in values):
        raise SdfSyntaxError(
            f"{where}: {describe(element)}: {element.text!r} needs {count} finite numbers"
        )
    return values[:count]


def _number(parent: etree._Element | None, tag: str, default: float, where: str) -> float:
    found = _numbers(parent.find(tag) if parent is not None else None, 1, where)
    return default if found is None else found[0]


def _rgb(element: etree._Element, tag: str, default: Vec3, scale: float, where: str) -> Vec3:
    found = _numbers(element.find(tag), 3, where)
    r, g, b = found if found is not None else default
    return (max(0.0, r * scale), max(0.0, g * scale), max(0.0, b * scale))


def _light(
    element: etree._Element, source: Path, version: tuple[int, int], at: Pose | None
) -> WorldLight | None:
    where = str(source)
    kind = element.get("type", "point").strip()
    if kind not in ("directional", "point", "spot"):
        raise SdfSyntaxError(
            f"{where}: {describe(element)}: light type {kind!r} is not directional, point or spot"
        )
    on = element.find("light_on")
    if on is not None and (on.text or "").strip().lower() in ("false", "0"):
        return None
    pose = at if at is not None else _parse_pose(element.find("pose"), source, version).pose
    intensity = _number(element, "intensity", 1.0, where)
    direction = _numbers(element.find("direction"), 3, where) or (0.0, 0.0, -1.0)
    norm = math.sqrt(sum(d * d for d in direction))
    if norm == 0.0:
        raise SdfSyntaxError(f"{where}: {describe(element)}: <direction> is the zero vector")
    attenuation = element.find("attenuation")
    spot = element.find("spot")
    outer = _number(spot, "outer_angle", 0.0, where)
    return WorldLight(
        name=element.get("name", ""),
        kind=kind,
        pos=pose.xyz,
        dir=pose.rotate([d / norm for d in direction]),
        diffuse=_rgb(element, "diffuse", (1.0, 1.0, 1.0), intensity, where),
        specular=_rgb(element, "specular", (0.1, 0.1, 0.1), intensity, where),
        attenuation=(
            _number(attenuation, "constant", 1.0, where),
            _number(attenuation, "linear", 1.0, where),
            _number(attenuation, "quadratic", 0.0, where),
        ),
        range=_number(attenuation, "range", 10.0, where),
        cutoff=min(90.0, math.degrees(outer / 2.0)) if spot is not None else 45.0,
        exponent=_number(spot, "falloff", 0.0, where),
    )


def _included_light(
    element: etree._Element,
    source: Path,
    version: tuple[int, int],
    search_paths: Sequence[Path],
    stock: Path,
) -> WorldLight | None:
    """The light of a light-only ``<include>`` (None: it includes a model)."""
    where = f"{source}: {describe(element)}"
    uri = (element.findtext("uri") or "").strip()
    if not uri:
        return None  # the SDF reader names it
    try:
        found = include_file(uri, source, where, search_paths, light_ok=True)
    except SdfIncludeError:
        return None  # the SDF reader names it
    path = found if found is not None else stock
    root, _ = read_xml_file(path)
    text = root.get("version", "").strip()
    if root.find("model") is not None or text not in SUPPORTED_VERSIONS:
        return None
    light = root.find("light")
    if light is None:
        return None
    major, minor = text.split(".")
    pose_el = element.find("pose")
    at = _parse_pose(pose_el, source, version).pose if pose_el is not None else None
    found_light = _light(light, path, (int(major), int(minor)), at)
    name = element.findtext("name")
    if found_light is not None and name:
        return WorldLight(**{**found_light.__dict__, "name": name.strip()})
    return found_light


def world_lighting(
    world: etree._Element,
    source: Path,
    version: tuple[int, int],
    search_paths: Sequence[str | Path],
) -> Lighting:
    """The lighting of the SDF ``<world>`` element ``world`` read from ``source`` (see the
    module docstring); ``search_paths`` as for the world's includes, the last of them holding
    the harness's stock ``sun``."""
    ambient = _numbers(world.find("scene/ambient"), 3, str(source))
    background = _numbers(world.find("scene/background"), 3, str(source))
    paths = [Path(p) for p in search_paths]
    stock = paths[-1] / "sun" / "model.sdf" if paths else Path()
    lights: list[WorldLight] = []
    for child in world:
        if not isinstance(child.tag, str):
            continue
        if child.tag == "light":
            light = _light(child, source, version, None)
        elif child.tag == "include":
            light = _included_light(child, source, version, paths, stock)
        else:
            continue
        if light is not None:
            lights.append(light)
    return Lighting(
        (ambient[0], ambient[1], ambient[2]) if ambient is not None else SCENE_AMBIENT,
        tuple(lights),
        (background[0], background[1], background[2])
        if background is not None
        else SCENE_BACKGROUND,
    )


# MuJoCo's OpenGL renderer draws no light of type "point": a spot light with a 180 degree
# cutoff is OpenGL's point light.
_KINDS = {
    "directional": mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
    "point": mujoco.mjtLightType.mjLIGHT_SPOT,
    "spot": mujoco.mjtLightType.mjLIGHT_SPOT,
}


def apply_lighting(spec: mujoco.MjSpec, lighting: Lighting) -> None:
    """Light ``spec`` as ``lighting`` says: its lights in the world body, the headlight as the
    ambient light only."""
    if any(light.kind != "directional" for light in lighting.lights):
        # MuJoCo lights per vertex: a box face drawn as numquads^2 quads catches a point
        # light's fall-off (4 quads: a wall's face lit as the mean of its corners)
        spec.visual.quality.numquads = max(int(spec.visual.quality.numquads), NUMQUADS)
    spec.add_numeric(name=BACKGROUND_NUMERIC, size=3, data=list(lighting.background))
    headlight = spec.visual.headlight
    headlight.ambient = list(lighting.ambient)
    headlight.diffuse = [0.0, 0.0, 0.0]
    headlight.specular = [0.0, 0.0, 0.0]
    used: set[str] = set()
    for index, light in enumerate(lighting.lights):
        name = f"light:{light.name or index}"
        name = name if name not in used else f"{name}:{index}"
        used.add(name)
        added = spec.worldbody.add_light(
            name=name,
            type=_KINDS[light.kind],
            pos=list(light.pos),
            dir=list(light.dir),
            diffuse=list(light.diffuse),
            specular=list(light.specular),
            ambient=[0.0, 0.0, 0.0],
            castshadow=False,
        )
        if light.kind != "directional":
            added.attenuation = list(light.attenuation)
            added.range = light.range
        added.cutoff = light.cutoff if light.kind == "spot" else 180.0
        added.exponent = light.exponent if light.kind == "spot" else 0.0
