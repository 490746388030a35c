"""URDF into :class:`RobotModel` (read with lxml) and into the XML MuJoCo's importer gets.

Reading is done here rather than with yourdfpy because ``import yourdfpy`` alone costs ~0.7 s
against a 300 ms cold-start budget; yourdfpy stays the independent oracle in the tests.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import NamedTuple, cast

import numpy as np
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.description import (
    Geometry,
    Inertial,
    Joint,
    JointLimits,
    JointType,
    Link,
    Mimic,
    Pose,
    RobotModel,
    Shape,
)
from harness.models.errors import ModelStructureError
from harness.models.files.assets import mesh_asset
from harness.models.files.resolve import PackageMap, resolve_uri
from harness.models.files.xmlsafe import describe, read_xml_file

__all__ = [
    "JOINT_TYPES",
    "REPAIR_BOUNDINERTIA",
    "REPAIR_BOUNDMASS",
    "HarnessExtension",
    "PreparedURDF",
    "harness_extension",
    "mujoco_urdf_xml",
    "read_urdf",
    "urdf_from_element",
]

JOINT_TYPES: tuple[JointType, ...] = (
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
)

# Compiler bounds applied by ``repair_inertia=True``.
REPAIR_BOUNDMASS = 1e-4
REPAIR_BOUNDINERTIA = 1e-8


def _floats(
    element: etree._Element, attr: str, count: int, source: str, default: Sequence[float] | None
) -> tuple[float, ...]:
    text = element.get(attr)
    if text is None:
        if default is None:
            raise ModelStructureError(f"{source}: {describe(element)}: missing attribute {attr!r}")
        return tuple(default)
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        values = ()
    if len(values) != count:
        raise ModelStructureError(
            f"{source}: {describe(element)}: {attr}={text!r} is not {count} number(s)"
        )
    return values


def _origin(element: etree._Element, source: str) -> Pose:
    origin = element.find("origin")
    if origin is None:
        return Pose()
    xyz = _floats(origin, "xyz", 3, source, (0.0, 0.0, 0.0))
    rpy = _floats(origin, "rpy", 3, source, (0.0, 0.0, 0.0))
    return Pose.from_xyz_rpy(xyz, rpy)


def _geometry(element: etree._Element, owner: etree._Element, source: str) -> Geometry:
    geom = element.find("geometry")
    shape = None if geom is None else next((c for c in geom if isinstance(c.tag, str)), None)
    if shape is None:
        raise ModelStructureError(f"{source}: {describe(owner)}: <{element.tag}> has no geometry")
    kind = shape.tag
    if kind == "box":
        return Geometry("box", _floats(shape, "size", 3, source, None))
    if kind in ("cylinder", "capsule"):
        radius = _floats(shape, "radius", 1, source, None)[0]
        length = _floats(shape, "length", 1, source, None)[0]
        return Geometry("cylinder" if kind == "cylinder" else "capsule", (radius, length))
    if kind == "sphere":
        return Geometry("sphere", _floats(shape, "radius", 1, source, None))
    if kind == "mesh":
        filename = shape.get("filename")
        if not filename:
            raise ModelStructureError(f"{source}: {describe(owner)}: <mesh> without filename")
        scale_text = shape.get("scale")
        scale: tuple[float, ...] = (1.0, 1.0, 1.0)
        if scale_text is not None:
            scale = _floats(shape, "scale", len(scale_text.split()), source, None)
        if len(scale) == 1:
            scale = (scale[0],) * 3
        if len(scale) != 3:
            raise ModelStructureError(
                f"{source}: {describe(owner)}: mesh scale must be 1 or 3 numbers"
            )
        return Geometry("mesh", (), filename, (scale[0], scale[1], scale[2]))
    raise ModelStructureError(f"{source}: {describe(owner)}: unknown geometry <{kind}>")


def _inertial(element: etree._Element, link_pose: Pose, source: str) -> Inertial | None:
    inertial = element.find("inertial")
    if inertial is None:
        return None
    mass_el = inertial.find("mass")
    mass = 0.0 if mass_el is None else _floats(mass_el, "value", 1, source, None)[0]
    inertia_el = inertial.find("inertia")
    inertia: tuple[float, ...] = (0.0,) * 6
    if inertia_el is not None:
        inertia = tuple(
            _floats(inertia_el, key, 1, source, (0.0,))[0]
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        )
    i6 = (inertia[0], inertia[1], inertia[2], inertia[3], inertia[4], inertia[5])
    return Inertial(mass, link_pose * _origin(inertial, source), i6)


def _shapes(element: etree._Element, tag: str, link_pose: Pose, source: str) -> tuple[Shape, ...]:
    shapes = []
    for index, shape in enumerate(element.findall(tag)):
        name = shape.get("name") or f"{element.get('name')}_{tag}_{index}"
        pose = link_pose * _origin(shape, source)
        shapes.append(Shape(name, pose, _geometry(shape, element, source)))
    return tuple(shapes)


def _limits(joint: etree._Element, source: str) -> JointLimits:
    limit = joint.find("limit")
    if limit is None:
        return JointLimits()

    def opt(attr: str) -> float | None:
        if limit.get(attr) is None:
            return None
        return _floats(limit, attr, 1, source, None)[0]

    return JointLimits(opt("lower"), opt("upper"), opt("velocity"), opt("effort"))


def urdf_from_element(root: etree._Element, source: str) -> RobotModel:
    """A :class:`RobotModel` from a parsed ``<robot>`` element (``source`` names the file)."""
    if root.tag != "robot":
        raise ModelStructureError(f"{source}: root element is <{root.tag}>, expected <robot>")
    link_elements: dict[str, etree._Element] = {}
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise ModelStructureError(f"{source}: {describe(link)}: link without a name")
        if name in link_elements:
            raise ModelStructureError(f"{source}: {describe(link)}: duplicate link {name!r}")
        link_elements[name] = link
    if not link_elements:
        raise ModelStructureError(f"{source}: <robot> has no <link>")

    parent_of: dict[str, tuple[etree._Element, str]] = {}
    children: dict[str, list[etree._Element]] = {}
    joint_elements = root.findall("joint")
    for joint in joint_elements:
        jname = joint.get("name")
        if not jname:
            raise ModelStructureError(f"{source}: {describe(joint)}: joint without a name")
        jtype = joint.get("type")
        if jtype not in JOINT_TYPES:
            raise ModelStructureError(
                f"{source}: {describe(joint)}: unknown joint type {jtype!r} "
                f"(expected one of {', '.join(JOINT_TYPES)})"
            )
        ends = {}
        for end in ("parent", "child"):
            end_el = joint.find(end)
            link_name = None if end_el is None else end_el.get("link")
            if not link_name:
                raise ModelStructureError(f"{source}: {describe(joint)}: missing <{end} link=...>")
            if link_name not in link_elements:
                raise ModelStructureError(
                    f"{source}: {describe(joint)}: {end} link {link_name!r} does not exist"
                )
            ends[end] = link_name
        if ends["child"] in parent_of:
            raise ModelStructureError(
                f"{source}: {describe(joint)}: link {ends['child']!r} has two parent joints"
            )
        parent_of[ends["child"]] = (joint, ends["parent"])
        children.setdefault(ends["parent"], []).append(joint)

    roots = [name for name in link_elements if name not in parent_of]
    if not roots:
        raise ModelStructureError(f"{source}: the joints form a cycle (no root link)")
    link_pose: dict[str, Pose] = {}
    joints: dict[str, Joint] = {}
    stack = [(name, Pose()) for name in reversed(roots)]
    while stack:
        name, pose = stack.pop()
        link_pose[name] = pose
        for joint in reversed(children.get(name, [])):
            child = joint.find("child")
            assert child is not None
            child_name = str(child.get("link"))
            jpose = pose * _origin(joint, source)
            joints[str(joint.get("name"))] = _joint(joint, name, child_name, jpose, source)
            stack.append((child_name, jpose))
    if len(link_pose) != len(link_elements):
        cyclic = sorted(set(link_elements) - set(link_pose))
        raise ModelStructureError(f"{source}: the joints form a cycle through links {cyclic}")

    links = tuple(
        Link(
            name,
            link_pose[name],
            _inertial(element, link_pose[name], source),
            _shapes(element, "collision", link_pose[name], source),
            _shapes(element, "visual", link_pose[name], source),
        )
        for name, element in link_elements.items()
    )
    ordered = tuple(joints[str(j.get("name"))] for j in joint_elements)
    for joint in ordered:
        if joint.mimic is not None and joint.mimic.joint not in joints:
            raise ModelStructureError(
                f'{source}: <joint name="{joint.name}">: mimics unknown joint {joint.mimic.joint!r}'
            )
    return RobotModel(
        str(root.get("name") or Path(source).stem), links, ordered, (), source, "urdf"
    )


def _joint(element: etree._Element, parent: str, child: str, pose: Pose, source: str) -> Joint:
    jtype = cast(JointType, element.get("type"))  # checked by the caller
    axis: tuple[float, float, float] = (0.0, 0.0, 0.0)
    if jtype in ("revolute", "continuous", "prismatic", "planar"):
        axis_el = element.find("axis")
        local: tuple[float, ...] = (1.0, 0.0, 0.0)
        if axis_el is not None:
            local = _floats(axis_el, "xyz", 3, source, (1.0, 0.0, 0.0))
        norm = sum(c * c for c in local) ** 0.5
        if norm == 0.0:
            raise ModelStructureError(f"{source}: {describe(element)}: zero-length axis")
        axis = pose.rotate([c / norm for c in local])
    mimic = None
    mimic_el = element.find("mimic")
    if mimic_el is not None:
        target = mimic_el.get("joint")
        if not target:
            raise ModelStructureError(f"{source}: {describe(element)}: <mimic> without joint")
        mimic = Mimic(
            target,
            _floats(mimic_el, "multiplier", 1, source, (1.0,))[0],
            _floats(mimic_el, "offset", 1, source, (0.0,))[0],
        )
    damping = friction = 0.0
    dynamics = element.find("dynamics")
    if dynamics is not None:
        damping = _floats(dynamics, "damping", 1, source, (0.0,))[0]
        friction = _floats(dynamics, "friction", 1, source, (0.0,))[0]
    return Joint(
        str(element.get("name")),
        jtype,
        parent,
        child,
        pose,
        axis,
        _limits(element, source),
        mimic,
        damping,
        friction,
    )


class HarnessExtension(NamedTuple):
    """What a URDF's ``<harness>`` element adds to the robot (other URDF readers ignore it).

    ``keyframes``: name -> joint -> position (mimic followers filled in from their leader);
    ``armature``: joint -> reflected rotor inertia of its drive (kg m^2, kg for prismatic).
    """

    keyframes: Mapping[str, Mapping[str, float]]
    armature: Mapping[str, float]


_SCALAR_JOINTS = ("revolute", "continuous", "prismatic")


def _extension_joint(element: etree._Element, description: RobotModel, source: str) -> str:
    """The name of the one-degree-of-freedom joint an extension element refers to."""
    name = element.get("name")
    if not name:
        raise ModelStructureError(f"{source}: {describe(element)}: <joint> without a name")
    if not any(j.name == name and j.type in _SCALAR_JOINTS for j in description.joints):
        movable = [j.name for j in description.joints if j.type in _SCALAR_JOINTS]
        raise ModelStructureError(
            f"{source}: {describe(element)}: {name!r} is not a revolute, continuous or "
            f"prismatic joint of the robot (those are: {movable})"
        )
    return str(name)


def harness_extension(root: etree._Element, description: RobotModel) -> HarnessExtension:
    """The ``<harness>`` element of a parsed URDF ``<robot>`` (empty when there is none)::

        <harness>
          <keyframe name="home"><joint name="joint1" value="0.5"/> ...</keyframe>
          <joint name="joint1" armature="0.1"/>
        </harness>

    A keyframe's unlisted joints stay at zero (mimic followers follow their leader).
    """
    source = description.source or "<urdf>"
    keyframes: dict[str, dict[str, float]] = {}
    armature: dict[str, float] = {}
    elements = root.findall("harness")
    if len(elements) > 1:
        raise ModelStructureError(f"{source}: {describe(elements[1])}: more than one <harness>")
    for child in elements[0] if elements else ():
        if not isinstance(child.tag, str):
            continue  # comments
        if child.tag == "keyframe":
            key = child.get("name")
            if not key:
                raise ModelStructureError(f"{source}: {describe(child)}: keyframe without a name")
            if key in keyframes:
                raise ModelStructureError(
                    f"{source}: {describe(child)}: duplicate keyframe {key!r}"
                )
            values: dict[str, float] = {}
            for joint_el in child:
                if not isinstance(joint_el.tag, str):
                    continue
                if joint_el.tag != "joint":
                    raise ModelStructureError(
                        f"{source}: {describe(joint_el)}: unexpected <{joint_el.tag}> in "
                        "<keyframe> (expected <joint name=... value=...>)"
                    )
                name = _extension_joint(joint_el, description, source)
                values[name] = _floats(joint_el, "value", 1, source, None)[0]
            for joint in description.joints:
                if joint.mimic is not None and joint.name not in values:
                    lead = values.get(joint.mimic.joint)
                    if lead is not None:
                        values[joint.name] = joint.mimic.multiplier * lead + joint.mimic.offset
            keyframes[key] = values
        elif child.tag == "joint":
            name = _extension_joint(child, description, source)
            value = _floats(child, "armature", 1, source, None)[0]
            if not value >= 0.0:
                raise ModelStructureError(
                    f"{source}: {describe(child)}: armature {value!r} is negative"
                )
            armature[name] = value
        else:
            raise ModelStructureError(
                f"{source}: {describe(child)}: unexpected <{child.tag}> in <harness> "
                "(expected <keyframe> or <joint>)"
            )
    return HarnessExtension(keyframes, armature)


def read_urdf(path: str | Path) -> RobotModel:
    """Read the URDF file at ``path`` into a :class:`RobotModel`."""
    root, _ = read_xml_file(path)
    return urdf_from_element(root, str(path))


def _gazebo_materials(doc: etree._Element, source: str) -> None:
    """Colour the visuals of each link a ``<gazebo reference="link"><material>Gazebo/...``
    names as Gazebo does: the stock material replaces the URDF's own colour."""
    from harness.models.sdf.materials import gazebo_appearance  # the table: only with visuals

    links = {str(link.get("name")): link for link in doc.findall("link")}
    for gazebo in doc.findall("gazebo"):
        link = links.get(gazebo.get("reference") or "")
        material = gazebo.find("material")
        if link is None or material is None or not (material.text or "").strip():
            continue
        name = (material.text or "").strip()
        appearance = gazebo_appearance(name, f"{source}: {describe(material)}")
        if appearance is None:
            continue
        for visual in link.findall("visual"):
            for old in visual.findall("material"):
                visual.remove(old)
            added = etree.SubElement(visual, "material", {"name": f"gazebo:{name}"})
            rgba = " ".join(repr(float(v)) for v in appearance.rgba)
            etree.SubElement(added, "color", {"rgba": rgba})


class PreparedURDF(NamedTuple):
    """What :func:`mujoco_urdf_xml` hands over: the URDF text for MuJoCo, the inertia
    repairs made in it, each repaired link's new tensor (ixx, ixy, ixz, iyy, iyz, izz), and
    the mesh files the text names (asset name -> bytes, see :mod:`harness.models.files.assets`)."""

    xml: str
    repairs: tuple[str, ...]
    inertias: Mapping[str, tuple[float, ...]]
    assets: Mapping[str, bytes] = MappingProxyType({})


_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _repair_tensor(link: etree._Element) -> tuple[float, ...] | None:
    """Make a non positive-definite inertia tensor definite (eigenvalues raised to the
    bound, axes kept); MuJoCo's balanceinertia handles only the diagonal case."""
    inertia = link.find("inertial/inertia")
    if inertia is None:
        return None
    try:
        ixx, ixy, ixz, iyy, iyz, izz = (float(inertia.get(k) or 0.0) for k in _INERTIA_KEYS)
    except ValueError:
        return None
    if ixy == ixz == iyz == 0.0:
        return None
    if not all(np.isfinite(v) for v in (ixx, ixy, ixz, iyy, iyz, izz)):
        return None  # not a tensor to repair: MuJoCo names the bad value
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    values, vectors = np.linalg.eigh(tensor)
    if values.min() >= REPAIR_BOUNDINERTIA:
        return None
    fixed = vectors @ np.diag(np.maximum(values, REPAIR_BOUNDINERTIA)) @ vectors.T
    new = (fixed[0, 0], fixed[0, 1], fixed[0, 2], fixed[1, 1], fixed[1, 2], fixed[2, 2])
    for key, value in zip(_INERTIA_KEYS, new, strict=True):
        inertia.set(key, repr(float(value)))
    return tuple(float(v) for v in new)


def mujoco_urdf_xml(
    root: etree._Element,
    path: str | Path,
    *,
    packages: PackageMap | None = None,
    visuals: bool = False,
    repair_inertia: bool = False,
    cache_dir: str | Path | None = None,
) -> PreparedURDF:
    """The URDF text to hand to MuJoCo's importer.

    Mesh references are resolved and converted, and named by content
    (:func:`harness.models.files.assets.mesh_asset`): pass ``assets`` to ``MjSpec.from_string``;
    visual elements are dropped unless ``visuals`` (then a link's ``<gazebo reference>``
    ``<material>Gazebo/...`` colours its visuals); a ``<mujoco><compiler>`` element keeps
    every link a named body (``fusestatic="false"``) and, with ``repair_inertia``, sets the
    mass/inertia bounds and ``balanceinertia``; non positive-definite tensors are fixed here.
    """
    source = str(path)
    base_dir = Path(path).resolve().parent
    doc = copy.deepcopy(root)
    if not visuals:
        for visual in doc.findall("link/visual"):
            parent = visual.getparent()
            if parent is not None:
                parent.remove(visual)
    else:
        _gazebo_materials(doc, source)
    repairs: list[str] = []
    inertias: dict[str, tuple[float, ...]] = {}
    assets: dict[str, bytes] = {}
    for link in doc.findall("link"):
        for mesh in link.findall("*/geometry/mesh"):
            uri = mesh.get("filename")
            if not uri:
                continue  # urdf_from_element reports it
            context = f"{source}: {describe(link)}"
            found = resolve_uri(
                uri, base_dir=base_dir, packages=packages, context=context, what="mesh"
            )
            asset = mesh_asset(found, cache_dir=cache_dir, context=context)
            assets[asset.name] = asset.data
            mesh.set("filename", asset.name)
        if repair_inertia:
            fixed = _repair_tensor(link)
            if fixed is not None:
                name = str(link.get("name"))
                inertias[name] = fixed
                repairs.append(
                    f"{name}: inertia tensor not positive definite, eigenvalues raised to "
                    f"{REPAIR_BOUNDINERTIA:g} kg m^2"
                )
    # Our own <mujoco> element replaces any in the file: the compiler settings are part of
    # the harness contract (named bodies, visual handling, explicit repairs). <harness> is
    # applied to the MjSpec by the caller (see harness_extension).
    for old in doc.findall("mujoco") + doc.findall("harness"):
        doc.remove(old)
    attrs = {
        "discardvisual": "false" if visuals else "true",
        "fusestatic": "false",
        "strippath": "false",
        "angle": "radian",
    }
    if repair_inertia:
        attrs |= {
            "balanceinertia": "true",
            "boundmass": repr(REPAIR_BOUNDMASS),
            "boundinertia": repr(REPAIR_BOUNDINERTIA),
        }
    mujoco_el = etree.Element("mujoco")
    etree.SubElement(mujoco_el, "compiler", attrs)
    doc.insert(0, mujoco_el)
    xml = etree.tostring(doc, encoding="unicode")
    return PreparedURDF(xml, tuple(repairs), inertias, MappingProxyType(assets))
