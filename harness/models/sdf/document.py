"""The SDFormat document: elements parsed into entities, and the frame graph that resolves them.

:func:`load_document` reads a ``<model>`` or ``<world>`` file (following ``<include>``) into a
tree of :class:`Entity` (world, model, link, joint, frame). :class:`SdfDocument` answers the
frame-semantics questions libsdformat answers: the pose of any entity relative to any frame
named in its scope (``relative_to``, ``__model__``, ``world``, ``M1::L1``), joint axes in any
frame, the link a frame is attached to. Per-version rules (1.4: axis in the model frame;
1.5-1.6: ``use_parent_model_frame`` and ``pose/@frame``; 1.7+: ``relative_to`` and
``expressed_in``; 1.8+: nested references, ``canonical_link``, ``placement_frame``; 1.9+:
``@degrees`` and ``@rotation_format``) follow the version of the file each element came from,
so an included model keeps its own version.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.description import Pose
from harness.models.errors import ModelWarning
from harness.models.files.xmlsafe import describe, read_xml_file
from harness.models.sdf.errors import (
    SdfCycleError,
    SdfFrameError,
    SdfIncludeError,
    SdfInertiaError,
    SdfStructureError,
    SdfSyntaxError,
    SdfVersionError,
)
from harness.models.sdf.includes import SUPPORTED_VERSIONS, include_file

__all__ = [
    "SUPPORTED_VERSIONS",
    "Axis",
    "Entity",
    "InertialSpec",
    "JointSpec",
    "RawPose",
    "SdfDocument",
    "ShapeSpec",
    "load_document",
]

Vec3 = tuple[float, float, float]
Version = tuple[int, int]


_UNLIMITED = 1e16  # SDFormat's default joint limit: |limit| >= this means "no limit"


@dataclass(frozen=True)
class RawPose:
    """A ``<pose>`` as written: the transform and the frame named by ``relative_to`` (``""``:
    the element's default frame)."""

    pose: Pose = field(default_factory=Pose)
    relative_to: str = ""


@dataclass(frozen=True)
class Axis:
    """An ``<axis>`` / ``<axis2>`` as written; ``expressed_in`` is ``""`` for the joint frame
    (1.4, and 1.5-1.6 ``use_parent_model_frame``, become ``"__model__"``)."""

    xyz: Vec3
    expressed_in: str = ""
    lower: float = -_UNLIMITED
    upper: float = _UNLIMITED
    effort: float = -1.0
    max_velocity: float = -1.0
    damping: float = 0.0
    friction: float = 0.0
    spring_reference: float = 0.0
    spring_stiffness: float = 0.0
    mimic_joint: str | None = None
    mimic_multiplier: float = 1.0
    mimic_offset: float = 0.0


@dataclass(frozen=True)
class JointSpec:
    """The joint-specific part of a joint entity, as written."""

    type: str
    parent: str
    child: str
    axes: tuple[Axis, ...] = ()
    thread_pitch: float | None = None


@dataclass(frozen=True)
class InertialSpec:
    """``<inertial>`` as written: pose relative to the link, inertia about the centre of mass
    in that pose's axes (ixx, ixy, ixz, iyy, iyz, izz)."""

    mass: float
    raw_pose: RawPose
    inertia: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class ShapeSpec:
    """A ``<collision>`` or ``<visual>`` as written; ``geometry_kind`` is the SDF element name
    (box, cylinder, ...), ``values`` its parameters by name, ``uri`` for meshes."""

    name: str
    raw_pose: RawPose
    geometry_kind: str
    values: dict[str, tuple[float, ...]]
    uri: str | None
    element: etree._Element


@dataclass(eq=False)
class Entity:
    """One element of the document: ``kind`` is world, model, link, joint or frame.

    ``path`` is the ``::``-scoped name from the document's top element (``""`` for the top
    element itself); ``scope`` is the enclosing model or world.
    """

    kind: str
    name: str
    path: str
    scope: Entity | None
    element: etree._Element
    source: Path
    version: Version
    raw_pose: RawPose = field(default_factory=RawPose)
    children: list[Entity] = field(default_factory=list)
    # model
    static: bool = False
    canonical_link: str = ""
    placement_frame: str = ""
    # frame
    attached_to: str = ""
    # joint
    joint: JointSpec | None = None
    # link
    inertial: InertialSpec | None = None
    collisions: tuple[ShapeSpec, ...] = ()
    visuals: tuple[ShapeSpec, ...] = ()

    def child(self, kind: str, name: str) -> Entity:
        """The direct child of ``kind`` named ``name`` (``KeyError`` if absent)."""
        for entity in self.children:
            if entity.kind == kind and entity.name == name:
                return entity
        raise KeyError(f"{self.kind} {self.path or self.name!r} has no {kind} {name!r}")

    def of_kind(self, kind: str) -> list[Entity]:
        """Direct children of ``kind`` in document order."""
        return [e for e in self.children if e.kind == kind]

    def walk(self) -> Iterator[Entity]:
        """This entity and every entity below it, depth first in document order."""
        yield self
        for entity in self.children:
            yield from entity.walk()

    def where(self) -> str:
        """``file: line N: <tag name="...">`` for error messages."""
        return f"{self.source}: {describe(self.element)}"


def _where(source: Path, element: etree._Element) -> str:
    return f"{source}: {describe(element)}"


def _parse_version(text: str | None, source: Path, element: etree._Element) -> Version:
    if text is None or text.strip() not in SUPPORTED_VERSIONS:
        found = "no version attribute" if text is None else f"version {text!r}"
        raise SdfVersionError(
            f"{_where(source, element)}: unsupported SDFormat {found} "
            f"(supported: {SUPPORTED_VERSIONS[0]}-{SUPPORTED_VERSIONS[-1]})"
        )
    major, minor = text.strip().split(".")
    return (int(major), int(minor))


def _floats(text: str | None, count: int | None, where: str, what: str) -> tuple[float, ...]:
    parts = (text or "").split()
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise SdfSyntaxError(f"{where}: {what} {text!r} is not a list of numbers") from None
    if count is not None and len(values) != count:
        raise SdfSyntaxError(f"{where}: {what} {text!r} needs {count} numbers, not {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise SdfSyntaxError(f"{where}: {what} {text!r} is not finite")
    return values


def _bool(text: str | None, where: str, what: str) -> bool:
    value = (text or "").strip().lower()
    if value in ("true", "1"):
        return True
    if value in ("false", "0"):
        return False
    raise SdfSyntaxError(f"{where}: {what} {text!r} is not a boolean")


def _child_float(element: etree._Element, tag: str, default: float, source: Path) -> float:
    found = element.find(tag)
    if found is None or not (found.text or "").strip():
        return default
    return _floats(found.text, 1, _where(source, found), tag)[0]


def _parse_pose(element: etree._Element | None, source: Path, version: Version) -> RawPose:
    if element is None:
        return RawPose()
    where = _where(source, element)
    relative_to = element.get("relative_to" if version >= (1, 7) else "frame", "").strip()
    rotation_format = element.get("rotation_format", "euler_rpy")
    degrees = _bool(element.get("degrees", "false"), where, "degrees")
    text = element.text or ""
    if not text.split():
        return RawPose(Pose(), relative_to)
    if rotation_format == "euler_rpy":
        values = _floats(text, 6, where, "pose")
        rpy = values[3:]
        if degrees:
            rpy = tuple(math.radians(v) for v in rpy)
        return RawPose(Pose.from_xyz_rpy(values[:3], rpy), relative_to)
    if rotation_format == "quat_xyzw":
        if degrees:
            raise SdfSyntaxError(f'{where}: degrees="true" cannot be used with quat_xyzw')
        values = _floats(text, 7, where, "pose")
        qx, qy, qz, qw = values[3:]
        if qx == qy == qz == qw == 0.0:
            raise SdfSyntaxError(f"{where}: pose quaternion is zero")
        pose = Pose((values[0], values[1], values[2]), (qw, qx, qy, qz)).normalized()
        return RawPose(pose, relative_to)
    raise SdfSyntaxError(
        f"{where}: unknown rotation_format {rotation_format!r} (euler_rpy or quat_xyzw)"
    )


def _check_inertia(
    mass: float, inertia: Sequence[float], where: str, strict: bool = True
) -> tuple[float, float, float, float, float, float]:
    """The inertia tensor to use: as written when valid; else, unless ``strict``, repaired
    (principal moments raised to satisfy positivity and the triangle inequality, axes kept)
    with a :class:`ModelWarning` saying what changed (libsdformat loads such files too)."""
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    if mass == 0.0:
        # libsdformat accepts it: a static or welded link (a moving one fails to build)
        return (ixx, ixy, ixz, iyy, iyz, izz)
    if not mass > 0.0:
        raise SdfInertiaError(f"{where}: invalid inertia: mass {mass} must be positive")
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    moments, axes = np.linalg.eigh(tensor)
    tol = 1e-9 * float(np.max(np.abs(moments)))  # relative: rounding, not a tiny moment
    problem = None
    if float(moments[0]) <= 0.0:
        problem = f"principal moments {moments.tolist()} must be positive"
    elif float(moments[0] + moments[1]) < float(moments[2]) - tol:
        problem = f"principal moments {moments.tolist()} violate the triangle inequality"
    if problem is None:
        return (ixx, ixy, ixz, iyy, iyz, izz)
    if strict:
        raise SdfInertiaError(f"{where}: invalid inertia: {problem}")
    fixed = np.maximum(moments, _MIN_MOMENT)
    if fixed[0] + fixed[1] < fixed[2]:  # raise the two small ones to half the largest
        fixed[0] = max(fixed[0], fixed[2] / 2.0)
        fixed[1] = max(fixed[1], fixed[2] / 2.0)
    new = axes @ np.diag(fixed) @ axes.T
    warnings.warn(
        f"{where}: invalid inertia ({problem}): repaired to principal moments "
        f"{np.round(fixed, 9).tolist()} (strict=True refuses instead)",
        ModelWarning,
        stacklevel=2,
    )
    return (new[0, 0], new[0, 1], new[0, 2], new[1, 1], new[1, 2], new[2, 2])


_MIN_MOMENT = 1e-8


class _Loader:
    """Builds the entity tree of one document (following includes)."""

    def __init__(self, search_paths: Sequence[str | Path], strict: bool = True) -> None:
        self.search_paths = [Path(p) for p in search_paths]
        self.include_stack: list[Path] = []
        self.strict = strict

    def load_root(self, path: Path) -> tuple[Entity, str]:
        self.include_stack.append(path.resolve())
        root, version, version_text = self._read_sdf(path)
        top = [c for c in root if isinstance(c.tag, str) and c.tag in ("world", "model")]
        if not top:
            raise SdfStructureError(f"{_where(path, root)}: no <world> or <model> element")
        element = top[0]
        if element.tag == "world":
            return self._world(element, path, version), version_text
        return self._model(element, None, path, version), version_text

    def _read_sdf(self, path: Path) -> tuple[etree._Element, Version, str]:
        root, _ = read_xml_file(path)
        if root.tag != "sdf":
            raise SdfSyntaxError(f"{_where(path, root)}: the top element must be <sdf>")
        version = _parse_version(root.get("version"), path, root)
        return root, version, f"{version[0]}.{version[1]}"

    def _world(self, element: etree._Element, source: Path, version: Version) -> Entity:
        world = Entity("world", element.get("name", ""), "", None, element, source, version)
        for child in element:
            if not isinstance(child.tag, str):
                continue
            if child.tag == "model":
                world.children.append(self._model(child, world, source, version))
            elif child.tag == "include":
                included = self._include(child, world, source, version, light_ok=True)
                if included is not None:  # a light-only include (Gazebo's sun) has no physics
                    world.children.append(included)
            elif child.tag == "frame":
                world.children.append(self._frame(child, world, source, version))
        self._check_names(world)
        self._apply_state(world, element, source, version)
        return world

    def _apply_state(
        self, world: Entity, element: etree._Element, source: Path, version: Version
    ) -> None:
        """A Gazebo Classic world's ``<state>``: each model's ``<pose>`` there (in the world
        frame) is where the model is, as Gazebo places it on load."""
        state = element.find("state")
        if state is None:
            return
        models = {c.name: c for c in world.children if c.kind == "model"}
        for entry in state.findall("model"):
            target = models.get(entry.get("name", ""))
            pose_el = entry.find("pose")
            if target is not None and pose_el is not None and (pose_el.text or "").split():
                target.raw_pose = RawPose(_parse_pose(pose_el, source, version).pose)

    def _model(
        self,
        element: etree._Element,
        scope: Entity | None,
        source: Path,
        version: Version,
        *,
        name: str | None = None,
        raw_pose: RawPose | None = None,
        static: bool | None = None,
        placement_frame: str | None = None,
    ) -> Entity:
        where = _where(source, element)
        model_name = name if name is not None else element.get("name", "")
        if not model_name:
            raise SdfStructureError(f"{where}: <model> needs a name")
        model = Entity(
            "model",
            model_name,
            _scoped(scope, model_name) if scope is not None else "",
            scope,
            element,
            source,
            version,
        )
        model.raw_pose = (
            raw_pose if raw_pose is not None else _parse_pose(element.find("pose"), source, version)
        )
        static_el = element.find("static")
        model.static = (
            static
            if static is not None
            else (static_el is not None and _bool(static_el.text, where, "static"))
        )
        model.canonical_link = element.get("canonical_link", "") if version >= (1, 8) else ""
        model.placement_frame = (
            placement_frame
            if placement_frame is not None
            else (element.get("placement_frame", "") if version >= (1, 8) else "")
        )
        for child in element:
            if not isinstance(child.tag, str):
                continue
            if child.tag == "link":
                model.children.append(self._link(child, model, source, version))
            elif child.tag == "joint":
                model.children.append(self._joint(child, model, source, version))
            elif child.tag == "frame":
                model.children.append(self._frame(child, model, source, version))
            elif child.tag == "model":
                model.children.append(self._model(child, model, source, version))
            elif child.tag == "include":
                included = self._include(child, model, source, version)
                assert included is not None  # light_ok=False: a light-only include raises
                model.children.append(included)
        self._check_names(model)
        return model

    def _check_names(self, scope: Entity) -> None:
        """Unique sibling names (1.7+); before 1.7 a frame that shares a name is renamed
        ``<name>_frame``, as libsdformat's 1.6 -> 1.7 conversion does."""
        seen: dict[str, Entity] = {}
        for entity in scope.children:
            if entity.kind == "frame" and entity.version < (1, 7):
                others = {e.name for e in scope.children if e is not entity}
                while entity.name in others:
                    entity.name += "_frame"
                entity.path = _scoped(scope, entity.name)
            if entity.name in seen and entity.version >= (1, 7):
                raise SdfStructureError(
                    f"{entity.where()}: name {entity.name!r} is already used by "
                    f"{seen[entity.name].kind} {describe(seen[entity.name].element)} in "
                    f"{scope.kind} {scope.name!r}"
                )
            if entity.name in ("world", "__model__") or (
                entity.name.startswith("__") and entity.name.endswith("__")
            ):
                raise SdfStructureError(f"{entity.where()}: name {entity.name!r} is reserved")
            seen.setdefault(entity.name, entity)

    def _frame(
        self, element: etree._Element, scope: Entity, source: Path, version: Version
    ) -> Entity:
        name = element.get("name", "")
        if not name:
            raise SdfStructureError(f"{_where(source, element)}: <frame> needs a name")
        frame = Entity("frame", name, _scoped(scope, name), scope, element, source, version)
        frame.attached_to = element.get("attached_to", "").strip()
        frame.raw_pose = _parse_pose(element.find("pose"), source, version)
        return frame

    def _link(
        self, element: etree._Element, scope: Entity, source: Path, version: Version
    ) -> Entity:
        name = element.get("name", "")
        if not name:
            raise SdfStructureError(f"{_where(source, element)}: <link> needs a name")
        link = Entity("link", name, _scoped(scope, name), scope, element, source, version)
        link.raw_pose = _parse_pose(element.find("pose"), source, version)
        inertial = element.find("inertial")
        if inertial is not None:
            link.inertial = self._inertial(inertial, source, version, _in_static(scope))
        link.collisions = tuple(
            self._shape(e, source, version) for e in element.findall("collision")
        )
        link.visuals = tuple(self._shape(e, source, version) for e in element.findall("visual"))
        return link

    def _inertial(
        self, element: etree._Element, source: Path, version: Version, static: bool
    ) -> InertialSpec:
        """The ``<inertial>``; a static model's is not judged (Gazebo ignores it: the link
        never moves)."""
        mass = _child_float(element, "mass", 1.0, source)
        tensor = element.find("inertia")
        defaults = {"ixx": 1.0, "ixy": 0.0, "ixz": 0.0, "iyy": 1.0, "iyz": 0.0, "izz": 1.0}
        values = [
            _child_float(tensor, key, default, source) if tensor is not None else default
            for key, default in defaults.items()
        ]
        inertia = (values[0], values[1], values[2], values[3], values[4], values[5])
        if not static:
            inertia = _check_inertia(mass, inertia, _where(source, element), self.strict)
        return InertialSpec(mass, _parse_pose(element.find("pose"), source, version), inertia)

    def _shape(self, element: etree._Element, source: Path, version: Version) -> ShapeSpec:
        where = _where(source, element)
        geometry = element.find("geometry")
        kinds = [c for c in geometry if isinstance(c.tag, str)] if geometry is not None else []
        if not kinds:
            raise SdfSyntaxError(f"{where}: needs a <geometry> with a shape")
        shape = kinds[0]
        values: dict[str, tuple[float, ...]] = {}
        for param in shape:
            if isinstance(param.tag, str) and param.tag not in ("uri", "submesh"):
                if list(param):
                    continue
                values[param.tag] = _floats(param.text, None, _where(source, param), param.tag)
        uri_el = shape.find("uri")
        uri = (uri_el.text or "").strip() if uri_el is not None else None
        return ShapeSpec(
            element.get("name", ""),
            _parse_pose(element.find("pose"), source, version),
            str(shape.tag),
            values,
            uri,
            shape,
        )

    def _joint(
        self, element: etree._Element, scope: Entity, source: Path, version: Version
    ) -> Entity:
        where = _where(source, element)
        name = element.get("name", "")
        if not name:
            raise SdfStructureError(f"{where}: <joint> needs a name")
        joint = Entity("joint", name, _scoped(scope, name), scope, element, source, version)
        joint.raw_pose = _parse_pose(element.find("pose"), source, version)
        parent = element.find("parent")
        child = element.find("child")
        if parent is None or not (parent.text or "").strip():
            raise SdfSyntaxError(f"{where}: needs a <parent>")
        if child is None or not (child.text or "").strip():
            raise SdfSyntaxError(f"{where}: needs a <child>")
        axes = []
        for tag in ("axis", "axis2"):
            axis = element.find(tag)
            if axis is not None:
                axes.append(self._axis(axis, source, version))
        pitch_el = element.find("thread_pitch")
        if version >= (1, 10) and element.find("screw_thread_pitch") is not None:
            pitch_el = element.find("screw_thread_pitch")
        pitch = None if pitch_el is None else _floats(pitch_el.text, 1, where, "thread_pitch")[0]
        joint.joint = JointSpec(
            element.get("type", ""),
            (parent.text or "").strip(),
            (child.text or "").strip(),
            tuple(axes),
            pitch,
        )
        return joint

    def _axis(self, element: etree._Element, source: Path, version: Version) -> Axis:
        where = _where(source, element)
        xyz_el = element.find("xyz")
        xyz = (
            (0.0, 0.0, 1.0)
            if xyz_el is None
            else _floats(xyz_el.text, 3, _where(source, xyz_el), "axis xyz")
        )
        if version < (1, 5):
            expressed_in = "__model__"
        elif version < (1, 7):
            upmf = element.find("use_parent_model_frame")
            in_model = upmf is not None and _bool(upmf.text, where, "use_parent_model_frame")
            expressed_in = "__model__" if in_model else ""
        else:
            expressed_in = xyz_el.get("expressed_in", "").strip() if xyz_el is not None else ""
        limit = element.find("limit")
        dynamics = element.find("dynamics")
        mimic = element.find("mimic") if version >= (1, 10) else None
        empty = etree.Element("empty")
        lim = limit if limit is not None else empty
        dyn = dynamics if dynamics is not None else empty
        return Axis(
            (xyz[0], xyz[1], xyz[2]),
            expressed_in,
            lower=_child_float(lim, "lower", -_UNLIMITED, source),
            upper=_child_float(lim, "upper", _UNLIMITED, source),
            effort=_child_float(lim, "effort", -1.0, source),
            max_velocity=_child_float(lim, "velocity", -1.0, source),
            damping=_child_float(dyn, "damping", 0.0, source),
            friction=_child_float(dyn, "friction", 0.0, source),
            spring_reference=_child_float(dyn, "spring_reference", 0.0, source),
            spring_stiffness=_child_float(dyn, "spring_stiffness", 0.0, source),
            mimic_joint=mimic.get("joint") if mimic is not None else None,
            mimic_multiplier=_child_float(mimic, "multiplier", 1.0, source)
            if mimic is not None
            else 1.0,
            mimic_offset=_child_float(mimic, "offset", 0.0, source) if mimic is not None else 0.0,
        )

    def _include(
        self,
        element: etree._Element,
        scope: Entity,
        source: Path,
        version: Version,
        light_ok: bool = False,
    ) -> Entity | None:
        where = _where(source, element)
        uri_el = element.find("uri")
        uri = (uri_el.text or "").strip() if uri_el is not None else ""
        if not uri:
            raise SdfIncludeError(f"{where}: <include> needs a <uri>")
        found = include_file(uri, source, where, self.search_paths, light_ok=light_ok)
        if found is None:
            return None  # a light-only stock model (Gazebo's sun): no physics
        path = found.resolve()
        if path in self.include_stack:
            chain = " -> ".join(str(p) for p in [*self.include_stack, path])
            raise SdfCycleError(f"{where}: include cycle: {chain}")
        self.include_stack.append(path)
        try:
            root, inc_version, _ = self._read_sdf(path)
            model_el = root.find("model")
            if model_el is None and light_ok and root.find("light") is not None:
                return None
            if model_el is None:
                raise SdfIncludeError(f"{where}: included file {path} has no <model>")
            name_el = element.find("name")
            static_el = element.find("static")
            pose_el = element.find("pose")
            placement_el = element.find("placement_frame")
            return self._model(
                model_el,
                scope,
                path,
                inc_version,
                name=(name_el.text or "").strip() if name_el is not None else None,
                # the include's pose replaces the model's, in the including file's version
                raw_pose=_parse_pose(pose_el, source, version) if pose_el is not None else None,
                static=_bool(static_el.text, where, "static") if static_el is not None else None,
                placement_frame=(placement_el.text or "").strip()
                if placement_el is not None
                else None,
            )
        finally:
            self.include_stack.pop()


def _in_static(scope: Entity | None) -> bool:
    """Whether ``scope`` or a model around it is static (its links never move)."""
    while scope is not None and scope.kind == "model":
        if scope.static:
            return True
        scope = scope.scope
    return False


def _scoped(scope: Entity | None, name: str) -> str:
    if scope is None or scope.kind == "world" or (not scope.path and scope.scope is None):
        return name
    return f"{scope.path}::{name}"


class SdfDocument:
    """A loaded SDFormat document and its frame graph (poses resolved on demand, cached)."""

    def __init__(self, root: Entity, version: str) -> None:
        self.root = root
        """The top ``<world>`` or ``<model>``."""
        self.version = version
        """The ``<sdf version>`` of the file as written (its original version)."""
        self.world = (
            root
            if root.kind == "world"
            else Entity("world", "world", "world", None, root.element, root.source, root.version)
        )
        """The world: the top element, or the implicit world a model file's joints may name."""
        self._in_scope: dict[int, Pose] = {}
        self._body: dict[int, Entity] = {}

    # --- names -------------------------------------------------------------------------

    def lookup(self, scope: Entity, name: str, context: Entity, what: str) -> Entity:
        """The entity ``name`` (``::``-scoped, ``__model__``, ``world``) names in ``scope``."""
        if name == "world" and (scope.kind == "world" or what in ("parent", "child")):
            return self.world
        current = scope
        parts = name.split("::")
        for index, part in enumerate(parts):
            if part == "__model__" and current.kind == "model":
                found: Entity | None = current
            else:
                found = next((e for e in current.children if e.name == part), None)
            last = index == len(parts) - 1
            if found is None or (not last and found.kind != "model"):
                raise SdfFrameError(
                    f"{context.where()}: unknown frame {name!r} in {what} "
                    f"(not found in {current.kind} {current.name!r})"
                )
            current = found
        return current

    def relative_name(self, entity: Entity, scope: Entity) -> str:
        """``entity``'s ``::``-scoped name as seen from ``scope`` (``__model__`` for the scope
        itself)."""
        if entity.kind == "world":
            return "world"
        if entity is scope:
            return "__model__"
        names: list[str] = []
        current: Entity | None = entity
        while current is not None and current is not scope:
            names.append(current.name)
            current = current.scope
        return "::".join(reversed(names))

    # --- poses --------------------------------------------------------------------------

    def default_frame(self, entity: Entity) -> Entity:
        """The frame ``entity``'s pose is relative to when ``relative_to`` is empty."""
        scope = entity.scope
        if scope is None:
            return entity
        if entity.kind == "joint" and entity.joint is not None:
            return self.lookup(scope, entity.joint.child, entity, "child")
        if entity.kind == "frame" and entity.attached_to:
            return self.lookup(scope, entity.attached_to, entity, "attached_to")
        return scope

    def pose_frame(self, entity: Entity) -> Entity:
        """The frame the written ``<pose>`` of ``entity`` is relative to."""
        if entity.scope is not None and entity.raw_pose.relative_to:
            return self.lookup(entity.scope, entity.raw_pose.relative_to, entity, "relative_to")
        return self.default_frame(entity)

    def pose_in_scope(self, entity: Entity, _stack: tuple[Entity, ...] = ()) -> Pose:
        """The pose of ``entity`` in the frame of its scope (its model or world)."""
        key = id(entity)
        cached = self._in_scope.get(key)
        if cached is not None:
            return cached
        scope = entity.scope
        if scope is None or entity.kind == "world":
            return Pose()
        if entity in _stack:
            chain = " -> ".join(e.path or e.name for e in (*_stack, entity))
            raise SdfCycleError(f"{entity.where()}: cycle in relative_to: {chain}")
        stack = (*_stack, entity)
        frame = self.pose_frame(entity)
        if frame is entity:
            raise SdfCycleError(
                f"{entity.where()}: cycle in relative_to: {entity.name} is relative to itself"
            )
        base = self._pose_in(frame, scope, stack)
        pose = base * entity.raw_pose.pose
        if entity.kind == "model" and entity.placement_frame:
            placement = self.lookup(entity, entity.placement_frame, entity, "placement_frame")
            pose = pose * self._pose_in(placement, entity, stack).inverse()
        self._in_scope[key] = pose
        return pose

    def _pose_in(self, entity: Entity, ancestor: Entity, stack: tuple[Entity, ...]) -> Pose:
        if entity is ancestor or entity.kind == "world":
            return Pose()
        pose = self.pose_in_scope(entity, stack)
        current = entity.scope
        while current is not None and current is not ancestor:
            pose = self.pose_in_scope(current, stack) * pose
            current = current.scope
        if current is None:
            raise SdfFrameError(f"{entity.where()}: frame is outside {ancestor.where()}")
        return pose

    def pose_in_root(self, entity: Entity) -> Pose:
        """The pose of ``entity`` in the top element's frame (the model or world frame)."""
        return self._pose_in(entity, self.root, ())

    def pose_in_model(self, entity: Entity, model: Entity) -> Pose:
        """The pose of ``entity`` in the frame of ``model`` (an ancestor of ``entity``)."""
        return self._pose_in(entity, model, ())

    def pose(self, entity: Entity, relative_to: str | None = None) -> Pose:
        """The pose of ``entity`` relative to the frame ``relative_to`` names in its scope;
        ``None``: relative to the scope itself (``__model__`` or ``world``), as libsdformat's
        ``SemanticPose().Resolve()`` does."""
        scope = entity.scope
        if scope is None:
            return Pose()
        frame = (
            scope if relative_to is None else self.lookup(scope, relative_to, entity, "relative_to")
        )
        return self.pose_in_root(frame).inverse() * self.pose_in_root(entity)

    # --- axes and attachment ------------------------------------------------------------

    def axis_in_root(self, joint: Entity, index: int = 0) -> Vec3:
        """Unit axis ``index`` of ``joint`` in the top element's frame."""
        assert joint.joint is not None
        assert joint.scope is not None
        axis = joint.joint.axes[index]
        frame = (
            joint
            if not axis.expressed_in
            else self.lookup(joint.scope, axis.expressed_in, joint, "expressed_in")
        )
        norm = math.sqrt(sum(c * c for c in axis.xyz))
        if norm == 0.0:
            raise SdfSyntaxError(f"{joint.where()}: axis xyz is the zero vector")
        unit = tuple(c / norm for c in axis.xyz)
        return self.pose_in_root(frame).rotate(unit)

    def axis(self, joint: Entity, index: int = 0, relative_to: str | None = None) -> Vec3:
        """Unit axis ``index`` of ``joint`` in the frame ``relative_to`` (``None``: the joint
        frame)."""
        assert joint.scope is not None
        frame = (
            joint
            if relative_to is None
            else self.lookup(joint.scope, relative_to, joint, "relative_to")
        )
        return self.pose_in_root(frame).inverse().rotate(self.axis_in_root(joint, index))

    def canonical_link(self, model: Entity) -> Entity:
        """The link a model frame is attached to: ``canonical_link``, else the first link,
        else the canonical link of the first nested model."""
        if model.canonical_link:
            link = self.lookup(model, model.canonical_link, model, "canonical_link")
            if link.kind != "link":
                raise SdfFrameError(
                    f"{model.where()}: canonical_link {model.canonical_link!r} is not a link"
                )
            return link
        links = model.of_kind("link")
        if links:
            return links[0]
        for nested in model.of_kind("model"):
            return self.canonical_link(nested)
        raise SdfStructureError(f"{model.where()}: model has no link to attach its frame to")

    def body(self, entity: Entity, _stack: tuple[Entity, ...] = ()) -> Entity:
        """The link (or the world) that ``entity``'s frame moves with."""
        cached = self._body.get(id(entity))
        if cached is not None:
            return cached
        if entity in _stack:
            chain = " -> ".join(e.path or e.name for e in (*_stack, entity))
            raise SdfCycleError(f"{entity.where()}: cycle in attached_to: {chain}")
        stack = (*_stack, entity)
        if entity.kind in ("link", "world"):
            found = entity
        elif entity.kind == "model":
            found = self.body(self.canonical_link(entity), stack)
        elif entity.kind == "joint":
            assert entity.joint is not None
            assert entity.scope is not None
            found = self.body(self.lookup(entity.scope, entity.joint.child, entity, "child"), stack)
        else:
            assert entity.scope is not None
            target = (
                self.lookup(entity.scope, entity.attached_to, entity, "attached_to")
                if entity.attached_to
                else entity.scope
            )
            if target is entity:
                raise SdfCycleError(
                    f"{entity.where()}: cycle in attached_to: {entity.name} is attached to itself"
                )
            found = self.body(target, stack)
        self._body[id(entity)] = found
        return found

    def joint_links(self, joint: Entity) -> tuple[Entity, Entity]:
        """The parent and child links (or world) of ``joint``."""
        assert joint.joint is not None
        assert joint.scope is not None
        parent = self.body(self.lookup(joint.scope, joint.joint.parent, joint, "parent"))
        child = self.body(self.lookup(joint.scope, joint.joint.child, joint, "child"))
        if child.kind == "world":
            raise SdfStructureError(f"{joint.where()}: the child cannot be the world")
        if parent is child:
            raise SdfStructureError(
                f"{joint.where()}: parent and child are the same link {child.path!r}"
            )
        return parent, child

    def validate(self) -> None:
        """Resolve every pose, attachment and axis once, so errors surface at load time."""
        for entity in self.root.walk():
            if entity.scope is None:
                continue
            self.pose_in_root(entity)
            if entity.kind in ("frame", "model"):
                self.body(entity)
            if entity.kind == "joint" and entity.joint is not None:
                self.joint_links(entity)
                for index in range(len(entity.joint.axes)):
                    self.axis_in_root(entity, index)


def load_document(
    path: str | Path, *, search_paths: Sequence[str | Path] | None = None, strict: bool = True
) -> SdfDocument:
    """Read the SDFormat file at ``path`` (``<include>``s searched in ``search_paths``, then
    the Gazebo variables GZ_SIM_RESOURCE_PATH, SDF_PATH, IGN_GAZEBO_RESOURCE_PATH,
    GAZEBO_MODEL_PATH, then the folders above the file) and check its frame graph.
    ``strict=False`` repairs invalid inertias with a warning instead of refusing them."""
    loader = _Loader(search_paths or (), strict)
    root, version = loader.load_root(Path(path))
    document = SdfDocument(root, version)
    document.validate()
    return document
