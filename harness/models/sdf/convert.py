"""SDFormat models as :class:`RobotModel`: every pose and axis in the model frame.

Names below the model are ``::``-scoped (``arm::link1``). Gazebo's semantics are made
explicit: a root link of a non-static model (see
:func:`~harness.models.sdf.build.spanning_tree`) gets a ``floating`` joint named
``<link>::__free__`` from ``world``; links of static models stay welded to the world;
``universal`` and ``revolute2`` joints become two revolute joints between the same links
(``<joint>`` and ``<joint>::axis2``, in that order); a link without ``<inertial>`` has
SDFormat's default (mass 1, unit inertia). ``gearbox`` joints have no equivalent and are
left out with a :class:`SdfWarning`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.models.description import (
    Geometry,
    GeometryKind,
    Inertial,
    Joint,
    JointLimits,
    JointType,
    Link,
    Mimic,
    ModelFrame,
    Pose,
    RobotModel,
    Shape,
)
from harness.models.errors import OutsideReferenceError, ResolveError
from harness.models.files.resolve import resolve_uri
from harness.models.sdf.build import spanning_tree
from harness.models.sdf.document import (
    Axis,
    Entity,
    SdfDocument,
    ShapeSpec,
    load_document,
)
from harness.models.sdf.errors import SdfStructureError, SdfSyntaxError, SdfWarning
from harness.models.sdf.materials import sdf_appearance

__all__ = [
    "FREE_JOINT_SUFFIX",
    "PlacedModel",
    "SdfWorld",
    "read_sdf",
    "read_sdf_world",
    "sdf_world",
    "to_robot_model",
]

FREE_JOINT_SUFFIX = "::__free__"
"""Suffix of the floating joint added to each root link of a non-static model."""

_UNLIMITED = 1e16


@dataclass(frozen=True)
class PlacedModel:
    """A model of a world: its pose in the world frame and its description."""

    name: str
    pose: Pose
    static: bool
    model: RobotModel


@dataclass(frozen=True)
class SdfWorld:
    """Every model of an SDFormat world (a model file gives a world of one model)."""

    name: str
    models: tuple[PlacedModel, ...]
    frames: tuple[ModelFrame, ...] = ()


def _limit(value: float) -> float | None:
    return None if abs(value) >= _UNLIMITED else value


def _positive(value: float) -> float | None:
    return value if value >= 0.0 else None


class _Converter:
    def __init__(self, doc: SdfDocument, model: Entity, search_paths: Sequence[str | Path]) -> None:
        self.doc = doc
        self.model = model
        self.search_paths = list(search_paths)
        self.to_model = doc.pose_in_root(model).inverse()

    def name(self, entity: Entity) -> str:
        if entity.kind == "world":
            return "world"
        return self.doc.relative_name(entity, self.model)

    def pose(self, entity: Entity) -> Pose:
        return self.to_model * self.doc.pose_in_root(entity)

    def axis(self, joint: Entity, index: int) -> tuple[float, float, float]:
        return self.to_model.rotate(self.doc.axis_in_root(joint, index))

    def convert(self) -> RobotModel:
        entities = list(self.model.walk())
        links = [self.link(e) for e in entities if e.kind == "link"]
        joints: list[Joint] = []
        for entity in entities:
            if entity.kind == "joint":
                joints.extend(self.joint(entity))
        by_name = {self.name(e): e for e in entities if e.kind == "link"}
        tree = spanning_tree(RobotModel(self.model.name, tuple(links), tuple(joints)))
        free: list[Joint] = []
        for name in tree.order:
            entity = by_name[name]
            if (
                tree.parent[name] == "world"
                and not tree.joints[name]
                and not self.is_static(entity)
            ):
                free.append(
                    Joint(name + FREE_JOINT_SUFFIX, "floating", "world", name, self.pose(entity))
                )
        frames = [
            self.frame(e) for e in entities if e.kind in ("frame", "model") and e is not self.model
        ]
        return RobotModel(
            name=self.model.name,
            links=tuple(links),
            joints=tuple(free + joints),
            frames=tuple(frames),
            source=str(self.model.source),
            format="sdf",
        )

    def is_static(self, entity: Entity) -> bool:
        scope = entity.scope
        while scope is not None and scope.kind == "model":
            if scope.static:
                return True
            if scope is self.model:
                break
            scope = scope.scope
        return False

    def link(self, entity: Entity) -> Link:
        pose = self.pose(entity)
        spec = entity.inertial
        if spec is None:
            inertial = Inertial(1.0, pose, (1.0, 0.0, 0.0, 1.0, 0.0, 1.0))
        else:
            inertial = Inertial(spec.mass, pose * spec.raw_pose.pose, spec.inertia)
        return Link(
            self.name(entity),
            pose,
            inertial,
            tuple(self.shape(entity, s, pose) for s in entity.collisions),
            tuple(self.shape(entity, s, pose, visual=True) for s in entity.visuals),
        )

    def shape(
        self, link: Entity, spec: ShapeSpec, link_pose: Pose, *, visual: bool = False
    ) -> Shape:
        where = f"{link.source}: line {spec.element.sourceline}: <{spec.geometry_kind}>"
        if spec.raw_pose.relative_to:
            frame = self.doc.lookup(
                link.scope or link, spec.raw_pose.relative_to, link, "relative_to"
            )
            pose = self.pose(frame) * spec.raw_pose.pose
        else:
            pose = link_pose * spec.raw_pose.pose
        values = spec.values

        def need(key: str, count: int) -> tuple[float, ...]:
            found = values.get(key)
            if found is None or len(found) != count:
                raise SdfSyntaxError(f"{where}: needs <{key}> with {count} number(s)")
            return found

        kind = spec.geometry_kind
        if kind == "box":
            geometry = Geometry("box", need("size", 3))
        elif kind in ("cylinder", "capsule"):
            round_kind: GeometryKind = "cylinder" if kind == "cylinder" else "capsule"
            geometry = Geometry(round_kind, (need("radius", 1)[0], need("length", 1)[0]))
        elif kind == "sphere":
            geometry = Geometry("sphere", need("radius", 1))
        elif kind == "ellipsoid":
            geometry = Geometry("ellipsoid", need("radii", 3))
        elif kind == "plane":
            normal = np.asarray(values.get("normal", (0.0, 0.0, 1.0)), dtype=float)
            pose = pose * _z_to(normal)
            geometry = Geometry("plane", values.get("size", ()))
        elif kind == "mesh":
            scale = values.get("scale", (1.0, 1.0, 1.0))
            geometry = Geometry(
                "mesh",
                (),
                self.mesh_path(spec.uri or "", link, where, visual=visual),
                (scale[0], scale[1], scale[2]),
            )
        else:
            raise SdfStructureError(f"{where}: geometry <{kind}> is not supported")
        element = spec.element.getparent()  # <geometry>, in the <visual>
        appearance = None
        if visual and element is not None and element.getparent() is not None:
            try:
                appearance = sdf_appearance(
                    element.getparent(),
                    str(link.source),
                    lambda uri, at: self.texture_path(uri, link, at),
                    mesh=kind == "mesh",
                )
            except SdfSyntaxError as exc:  # only drawing needs it: the model still loads
                warnings.warn(SdfWarning(f"{exc} (drawn grey)"), stacklevel=2)
        return Shape(spec.name, pose, geometry, appearance)

    def texture_path(self, uri: str, link: Entity, where: str) -> str | None:
        """The file of a texture ``uri`` (None, with a warning, when it is not at hand:
        the visual is drawn in its colour)."""
        try:
            return str(
                resolve_uri(
                    uri,
                    base_dir=link.source.parent,
                    search_paths=self.search_paths,
                    context=where,
                    what="texture",
                )
            )
        except OutsideReferenceError:
            raise
        except ResolveError as exc:
            warnings.warn(SdfWarning(f"{exc}: drawn without it"), stacklevel=2)
            return None

    def mesh_path(self, uri: str, link: Entity, where: str, *, visual: bool = False) -> str:
        if not uri:
            raise SdfSyntaxError(f"{where}: mesh needs a <uri>")
        try:
            return str(
                resolve_uri(
                    uri,
                    base_dir=link.source.parent,
                    search_paths=self.search_paths,
                    context=where,
                    what="mesh",
                )
            )
        except OutsideReferenceError:
            if visual:  # kept as text, never opened: a build with visuals leaves it out
                return uri
            raise  # a rebuild from a recording: refused, never looked up later
        except ResolveError:
            # Kept as written: inspecting a model does not need its meshes; building does.
            return uri

    def joint(self, entity: Entity) -> list[Joint]:
        spec = entity.joint
        assert spec is not None
        parent_entity, child_entity = self.doc.joint_links(entity)
        parent, child = self.name(parent_entity), self.name(child_entity)
        pose = self.pose(entity)
        name = self.name(entity)
        kind = spec.type
        if kind in ("revolute", "continuous", "prismatic"):
            axis = self.need_axis(entity, 0)
            one_dof: JointType = (
                "revolute"
                if kind == "revolute"
                else "continuous"
                if kind == "continuous"
                else "prismatic"
            )
            return [self.axis_joint(name, one_dof, parent, child, pose, entity, axis, 0)]
        if kind in ("universal", "revolute2"):
            first, second = self.need_axis(entity, 0), self.need_axis(entity, 1)
            return [
                self.axis_joint(name, "revolute", parent, child, pose, entity, first, 0),
                self.axis_joint(
                    name + "::axis2", "revolute", parent, child, pose, entity, second, 1
                ),
            ]
        if kind == "screw":
            axis = self.need_axis(entity, 0)
            return [self.axis_joint(name, "screw", parent, child, pose, entity, axis, 0)]
        if kind in ("ball", "fixed"):
            return [Joint(name, "ball" if kind == "ball" else "fixed", parent, child, pose)]
        if kind == "gearbox":
            warnings.warn(
                SdfWarning(
                    f"{entity.where()}: gearbox joints have no MuJoCo equivalent; "
                    "left out of the model"
                ),
                stacklevel=4,
            )
            return []
        raise SdfStructureError(f"{entity.where()}: unknown joint type {kind!r}")

    def need_axis(self, entity: Entity, index: int) -> Axis:
        assert entity.joint is not None
        if len(entity.joint.axes) <= index:
            return Axis((0.0, 0.0, 1.0))
        return entity.joint.axes[index]

    def axis_joint(
        self,
        name: str,
        kind: JointType,
        parent: str,
        child: str,
        pose: Pose,
        entity: Entity,
        axis: Axis,
        index: int,
    ) -> Joint:
        assert entity.joint is not None
        if len(entity.joint.axes) > index:
            direction = self.axis(entity, index)
        else:  # SDFormat's default axis: z of the joint frame
            direction = pose.rotate((0.0, 0.0, 1.0))
        lower, upper = _limit(axis.lower), _limit(axis.upper)
        if kind == "continuous":
            lower = upper = None
        mimic = None
        if axis.mimic_joint is not None:
            target = self.doc.lookup(entity.scope or entity, axis.mimic_joint, entity, "mimic")
            mimic = Mimic(self.name(target), axis.mimic_multiplier, axis.mimic_offset)
        return Joint(
            name,
            kind,
            parent,
            child,
            pose,
            direction,
            JointLimits(lower, upper, _positive(axis.max_velocity), _positive(axis.effort)),
            mimic,
            axis.damping,
            axis.friction,
        )

    def frame(self, entity: Entity) -> ModelFrame:
        if entity.kind == "model":
            body = self.doc.body(entity)
            return ModelFrame(self.name(entity) + "::__model__", self.name(body), self.pose(entity))
        assert entity.scope is not None
        target = (
            self.doc.lookup(entity.scope, entity.attached_to, entity, "attached_to")
            if entity.attached_to
            else entity.scope
        )
        # a frame stays the reference; a model frame, nested model, joint or link: its body
        attached = self.name(target if target.kind == "frame" else self.doc.body(target))
        return ModelFrame(self.name(entity), attached, self.pose(entity))


def _z_to(normal: np.ndarray) -> Pose:
    """A rotation taking +z to ``normal``."""
    n = normal / np.linalg.norm(normal)
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, n)
    c = float(np.dot(z, n))
    if np.linalg.norm(v) < 1e-12:
        return Pose() if c > 0 else Pose((0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0))
    w = 1.0 + c
    return Pose((0.0, 0.0, 0.0), (w, float(v[0]), float(v[1]), float(v[2]))).normalized()


def to_robot_model(
    doc: SdfDocument, model: Entity, *, search_paths: Sequence[str | Path] | None = None
) -> RobotModel:
    """The :class:`RobotModel` of ``model`` (an entity of ``doc``), in its own frame."""
    return _Converter(doc, model, search_paths or ()).convert()


def _models(doc: SdfDocument) -> list[Entity]:
    if doc.root.kind == "model":
        return [doc.root]
    return doc.root.of_kind("model")


def read_sdf(
    path: str | Path,
    *,
    search_paths: Sequence[str | Path] | None = None,
    model: str | None = None,
    strict: bool = True,
) -> RobotModel:
    """Read an SDFormat ``<model>`` file, or one model of a ``<world>`` file (``model``, else
    the first), as a :class:`RobotModel` in the model frame.

    ``search_paths``: folders searched first for ``model://`` includes and meshes.
    ``strict=False`` repairs invalid inertias with a warning (as ``load_robot`` does).
    """
    doc = load_document(path, search_paths=search_paths, strict=strict)
    models = _models(doc)
    if model is not None:
        chosen = [m for m in models if m.name == model]
        if not chosen:
            names = [m.name for m in models]
            raise SdfStructureError(f"{path}: no model named {model!r} (models: {names})")
    elif not models:
        raise SdfStructureError(f"{path}: the world has no model")
    else:
        chosen = models
    return to_robot_model(doc, chosen[0], search_paths=search_paths)


def read_sdf_world(
    path: str | Path, *, search_paths: Sequence[str | Path] | None = None, strict: bool = False
) -> SdfWorld:
    """Every model of an SDFormat file with its pose in the world (a ``<model>`` file gives
    one model placed at its own ``<pose>``), and the world's frames. A world is read as
    Gazebo reads it: a dynamic model's invalid inertia is repaired with a warning (as a
    robot's is) unless ``strict``; a static model's is not judged."""
    doc = load_document(path, search_paths=search_paths, strict=strict)
    return sdf_world(doc, search_paths=search_paths)


def sdf_world(doc: SdfDocument, *, search_paths: Sequence[str | Path] | None = None) -> SdfWorld:
    """The :class:`SdfWorld` of a loaded document (see :func:`read_sdf_world`)."""
    placed = []
    for entity in _models(doc):
        pose = entity.raw_pose.pose if doc.root.kind == "model" else doc.pose_in_root(entity)
        robot = to_robot_model(doc, entity, search_paths=search_paths)
        placed.append(PlacedModel(entity.name, pose, entity.static, robot))
    frames: list[ModelFrame] = []
    if doc.root.kind == "world":
        for frame in doc.root.of_kind("frame"):
            target = (
                doc.lookup(doc.root, frame.attached_to, frame, "attached_to")
                if frame.attached_to
                else doc.root
            )
            attached = doc.relative_name(
                target if target.kind in ("frame", "world") else doc.body(target), doc.root
            )
            frames.append(ModelFrame(frame.name, attached, doc.pose_in_root(frame)))
    return SdfWorld(doc.root.name, tuple(placed), tuple(frames))
