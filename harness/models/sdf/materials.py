"""Materials of SDF visuals as Gazebo (gz-sim) draws them, in MuJoCo's terms
(:class:`~harness.models.description.Appearance`).

gz-sim's renderer (ogre2, physically based) lights a surface's *diffuse* colour (its albedo):
the scene's ambient light and every light scale it; a material's ``<ambient>`` is stored but
not drawn. So a visual's ``rgba`` is its ``<diffuse>`` (its ``<ambient>`` when it writes no
diffuse, as Gazebo Classic would show it) with ``<transparency>`` in alpha; ``<emissive>`` is
the part drawn unlit (MuJoCo's ``emission``, a fraction of ``rgba``); ``<specular>`` the mean
of its colour. ``<pbr><metal><albedo_map>`` (or ``<specular>``'s) is a texture multiplied
with ``rgba`` (white when no diffuse is written). A ``<script><name>Gazebo/...`` names one of
Gazebo's stock materials: gz-sim reads its ambient, diffuse and specular from its own copy of
Gazebo Classic's ``media/materials/scripts/gazebo.material`` (:data:`GAZEBO_MATERIALS`, exact
names; gz-sim matches by substring, so ``Gazebo/Red`` there takes ``Gazebo/RedGlow``'s
values, the same red). A visual of a primitive shape with no ``<material>`` is gz-sim's
default grey (diffuse 0.7); a mesh visual without one has its own material: a COLLADA mesh's
diffuse colour when it has one colour (:func:`collada_appearance`), else MuJoCo's grey.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.description import Appearance
from harness.models.files.xmlsafe import describe
from harness.models.sdf.errors import SdfSyntaxError, SdfWarning

__all__ = [
    "DEFAULT_APPEARANCE",
    "GAZEBO_MATERIALS",
    "collada_appearance",
    "gazebo_appearance",
    "sdf_appearance",
]

Rgba = tuple[float, float, float, float]

DEFAULT_APPEARANCE = Appearance((0.7, 0.7, 0.7, 1.0), specular=0.5, source="gz-sim default")
"""gz-sim's material for a primitive visual without ``<material>`` ("gz-grey": ambient 0.3,
diffuse 0.7, specular 1)."""

# Ambient, diffuse and specular (None: not written) of the stock materials with a colour, read
# from gz-sim's src/rendering/MaterialParser/gazebo.material (Apache-2.0, commit 93bbf3ed) as
# its MaterialParser reads them: the first pass's values, numbers above 1 divided by 255.
GAZEBO_MATERIALS: dict[str, tuple[Rgba | None, Rgba | None, Rgba | None]] = {
    "Gazebo/Black": ((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/BlackTransparent": ((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), None),
    "Gazebo/Blue": ((0.0, 0.0, 1.0, 1.0), (0.0, 0.0, 1.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/BlueLaser": ((0.0, 0.0, 1.0, 1.0), (0.0, 0.0, 1.0, 1.0), None),
    "Gazebo/BlueTransparent": ((0.0, 0.0, 1.0, 1.0), (0.0, 0.0, 1.0, 1.0), None),
    "Gazebo/Bricks": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.2, 0.2, 0.2, 1.0)),
    "Gazebo/BuildingFrame": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.2, 0.2, 0.2, 1.0)),
    "Gazebo/CeilingTiled": ((0.5, 0.5, 0.5, 1.0), None, None),
    "Gazebo/CoM": ((0.5, 0.5, 0.5, 1.0), None, None),
    "Gazebo/DarkGray": (
        (0.175, 0.175, 0.175, 1.0),
        (0.175, 0.175, 0.175, 1.0),
        (0.175, 0.175, 0.175, 1.0),
    ),
    "Gazebo/DarkGrey": (
        (0.175, 0.175, 0.175, 1.0),
        (0.175, 0.175, 0.175, 1.0),
        (0.175, 0.175, 0.175, 1.0),
    ),
    "Gazebo/DarkMagentaTransparent": ((0.6, 0.0, 0.6, 1.0), (0.6, 0.0, 0.6, 1.0), None),
    "Gazebo/DarkOrangeTransparentOverlay": ((0.6, 0.305, 0.028, 1.0), None, None),
    "Gazebo/DarkYellow": ((0.7, 0.7, 0.0, 1.0), (0.7, 0.7, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0)),
    "Gazebo/Editor": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.1, 0.1, 0.1, 0.501961)),
    "Gazebo/EditorPlane": ((0.3, 0.3, 0.3, 1.0), (0.7, 0.7, 0.7, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/FlatBlack": ((0.1, 0.1, 0.1, 1.0), (0.1, 0.1, 0.1, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Footway": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Gold": (
        (0.4, 0.24869, 0.020759, 1.0),
        (0.8, 0.64869, 0.120759, 1.0),
        (0.4, 0.4, 0.4, 1.0),
    ),
    "Gazebo/Grass": ((0.5, 0.5, 0.5, 1.0), None, None),
    "Gazebo/Gray": ((0.3, 0.3, 0.3, 1.0), (0.7, 0.7, 0.7, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Green": ((0.0, 1.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/GreenTransparent": ((0.0, 1.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), None),
    "Gazebo/Grey": ((0.3, 0.3, 0.3, 1.0), (0.7, 0.7, 0.7, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/GreyTransparent": ((0.5, 0.5, 0.5, 1.0), (0.5, 0.5, 0.5, 1.0), None),
    "Gazebo/Indigo": ((0.33, 0.0, 0.5, 1.0), (0.33, 0.0, 0.5, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/JointAnchor": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0)),
    "Gazebo/Lane_1": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Lanes_2": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Lanes_4": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Lanes_6": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/LightBlueLaser": ((0.5, 0.5, 1.0, 1.0), (0.5, 0.5, 1.0, 1.0), None),
    "Gazebo/LightOff": ((1.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 1.0), None),
    "Gazebo/LightOn": ((0.0, 1.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), None),
    "Gazebo/Motorway": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Orange": (
        (1.0, 0.5088, 0.0468, 1.0),
        (1.0, 0.5088, 0.0468, 1.0),
        (0.5, 0.5, 0.5, 0.501961),
    ),
    "Gazebo/OrangeTransparent": ((1.0, 0.44, 0.0, 1.0), (1.0, 0.44, 0.0, 1.0), None),
    "Gazebo/OrangeTransparentOverlay": ((1.0, 0.5088, 0.0468, 1.0), None, None),
    "Gazebo/PaintedWall": ((1.0, 1.0, 1.0, 1.0), None, None),
    "Gazebo/Pedestrian": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Pioneer2Body": (
        (0.481193, 0.000123, 0.000123, 1.0),
        (0.681193, 0.000923, 0.000923, 1.0),
        (0.5, 0.5, 0.5, 1.0),
    ),
    "Gazebo/PioneerBody": ((0.5, 0.0, 0.0, 1.0), None, None),
    "Gazebo/PointCloud": ((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0)),
    "Gazebo/Primary": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Purple": ((1.0, 0.0, 1.0, 1.0), (1.0, 0.0, 1.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/Red": ((1.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/RedBright": ((0.87, 0.26, 0.07, 1.0), (0.87, 0.26, 0.07, 1.0), (0.87, 0.26, 0.07, 1.0)),
    "Gazebo/RedGlow": ((1.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.501961)),
    "Gazebo/Residential": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Road": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Runway": ((0.5, 0.5, 0.5, 1.0), None, None),
    "Gazebo/Secondary": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/SkyBlue": ((0.13, 0.44, 0.7, 1.0), (0.0, 0.0, 1.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/Steps": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Tertiary": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Trunk": ((0.1, 0.1, 0.1, 1.0), (0.8, 0.8, 0.8, 1.0), (0.01, 0.01, 0.01, 1.0)),
    "Gazebo/Turquoise": ((0.0, 1.0, 1.0, 1.0), (0.0, 1.0, 1.0, 1.0), (0.1, 0.1, 0.1, 1.0)),
    "Gazebo/TurquoiseGlowOutline": (None, (0.0, 1.0, 1.0, 1.0), (0.1, 0.1, 0.1, 0.501961)),
    "Gazebo/White": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.1, 0.1, 0.1, 0.501961)),
    "Gazebo/Wood": ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.2, 0.2, 0.2, 1.0)),
    "Gazebo/WoodFloor": ((0.5, 0.5, 0.5, 1.0), None, None),
    "Gazebo/WoodPallet": ((0.5, 0.5, 0.5, 1.0), (1.0, 1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 1.0)),
    "Gazebo/Yellow": ((1.0, 1.0, 0.0, 1.0), (1.0, 1.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0)),
    "Gazebo/YellowTransparent": ((1.0, 1.0, 0.0, 1.0), (1.0, 1.0, 0.0, 1.0), None),
    "Gazebo/ZincYellow": (
        (0.9725, 0.9529, 0.2078, 1.0),
        (0.9725, 0.9529, 0.2078, 1.0),
        (0.9725, 0.9529, 0.2078, 1.0),
    ),
}


def _mean(color: Sequence[float]) -> float:
    return float(sum(color[:3]) / 3.0)


def _color(element: etree._Element | None, where: str) -> Rgba | None:
    if element is None or not (element.text or "").split():
        return None
    try:
        values = [float(v) for v in (element.text or "").split()]
    except ValueError:
        values = []
    if len(values) not in (3, 4) or not all(math.isfinite(v) for v in values):
        raise SdfSyntaxError(
            f"{where}: {describe(element)}: colour {element.text!r} needs 3 or 4 numbers"
        )
    if len(values) == 3:
        values.append(1.0)
    r, g, b, a = (min(1.0, max(0.0, v)) for v in values)  # clamped, as gz clamps
    return (r, g, b, a)


def gazebo_appearance(name: str, where: str = "") -> Appearance | None:
    """The appearance of Gazebo's stock material ``name`` (``Gazebo/Red``), None (with an
    :class:`SdfWarning`) for a name it does not know."""
    found = GAZEBO_MATERIALS.get(name.strip())
    if found is None:
        prefix = f"{where}: " if where else ""
        warnings.warn(
            SdfWarning(f"{prefix}unknown Gazebo material {name.strip()!r}: drawn grey"),
            stacklevel=3,
        )
        return None
    ambient, diffuse, specular = found
    color = diffuse if diffuse is not None else ambient
    assert color is not None
    return Appearance(
        color,
        specular=_mean(specular) if specular is not None else 0.0,
        source=name.strip(),
    )


def sdf_appearance(
    visual: etree._Element,
    where: str,
    texture: Callable[[str, str], str | None],
    *,
    mesh: bool = False,
) -> Appearance | None:
    """The appearance of the SDF ``<visual>`` element ``visual`` (see the module docstring);
    ``texture(uri, where)`` resolves an image URI to a file (None: not at hand, drawn without
    it). ``mesh``: the visual is a mesh (no default material: Gazebo draws its own)."""
    material = visual.find("material")
    transparency_el = visual.find("transparency")
    opacity = 1.0
    if transparency_el is not None and (transparency_el.text or "").strip():
        try:
            opacity = 1.0 - min(1.0, max(0.0, float((transparency_el.text or "").strip())))
        except ValueError:
            raise SdfSyntaxError(
                f"{where}: {describe(transparency_el)}: {transparency_el.text!r} is not a number"
            ) from None
    if material is None:
        if mesh:
            return None
        base = DEFAULT_APPEARANCE
        r, g, b, a = base.rgba
        return Appearance((r, g, b, a * opacity), specular=base.specular, source=base.source)
    ambient = _color(material.find("ambient"), where)
    diffuse = _color(material.find("diffuse"), where)
    specular = _color(material.find("specular"), where)
    emissive = _color(material.find("emissive"), where)
    source = f"{where}: {describe(material)}"
    script = material.find("script/name")
    if script is not None and (script.text or "").strip().startswith("Gazebo/"):
        named = GAZEBO_MATERIALS.get((script.text or "").strip())
        if named is None:
            gazebo_appearance(script.text or "", where)  # warns
        else:  # gz-sim: the stock values replace those written
            ambient = named[0] or ambient
            diffuse = named[1] or diffuse
            specular = named[2] or specular
            source = (script.text or "").strip()
    image = None
    for path in ("pbr/metal/albedo_map", "pbr/specular/albedo_map"):
        found = material.find(path)
        if found is not None and (found.text or "").strip():
            image = texture((found.text or "").strip(), f"{where}: {describe(found)}")
            break
    color = diffuse if diffuse is not None else ambient
    if color is None:
        color = (1.0, 1.0, 1.0, 1.0) if image is not None else (0.0, 0.0, 0.0, 1.0)
    emission = 0.0
    if emissive is not None and _mean(emissive) > 0.0:
        if _mean(color) > 1e-6:
            emission = _mean(emissive) / _mean(color)
        else:  # only the glow shows: it is the colour, drawn unlit
            color, emission = (emissive[0], emissive[1], emissive[2], color[3]), 1.0
    r, g, b, a = color
    return Appearance(
        (r, g, b, a * opacity),
        emission=emission,
        specular=_mean(specular) if specular is not None else 0.0,
        texture=image,
        source=source,
    )


def collada_appearance(path: str) -> Appearance | None:
    """The colour of a COLLADA mesh drawn with its own material (a mesh visual without an SDF
    ``<material>``, as Gazebo draws it): the diffuse colour of its effects when they all have
    one and the same (``<lambert>``/``<phong>``/``<blinn>``); None for a textured or
    many-coloured mesh (drawn in MuJoCo's grey)."""
    from harness.models.files.xmlsafe import check_size, parse_xml

    source = Path(path)
    if source.suffix.lower() != ".dae" or not source.is_file():
        return None
    check_size(source)
    root = parse_xml(source.read_bytes(), path)
    colors: set[Rgba] = set()
    for element in root.iter():
        if not isinstance(element.tag, str) or element.tag.rpartition("}")[2] != "diffuse":
            continue
        children = [c for c in element if isinstance(c.tag, str)]
        if not children or children[0].tag.rpartition("}")[2] != "color":
            return None  # a texture
        color = _color(children[0], path)
        if color is not None:
            colors.add(color)
    if len(colors) != 1:
        return None
    return Appearance(colors.pop(), specular=0.0, source=path)
