"""Build a :class:`RobotModel` into a MuJoCo :class:`mujoco.MjSpec` (no actuators, no scene).

Bodies form a tree from the joints (:func:`spanning_tree`: the first joint that reaches a
link places it; a root link is welded to the world); joints that close a loop become equality
constraints: ``fixed`` a weld, ``ball`` a connect, ``revolute``/``continuous`` two connects
on the axis.
Joint types: revolute/continuous -> hinge, prismatic -> slide, ball -> ball, floating -> free,
planar -> two slides and a hinge, fixed -> the child body is welded to its parent; several
joints between the same two links (SDF ``universal``) share the child body, in order. Mimic
joints become joint equalities. The worldbody is the model frame.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import NamedTuple

import mujoco
import numpy as np

from harness.models.build.inertia import principal_on_edge
from harness.models.description import Appearance, Geometry, Joint, Link, Pose, RobotModel, Shape
from harness.models.errors import ModelStructureError, ResolveError
from harness.models.files.assets import asset_name, mesh_asset
from harness.models.files.confine import check_confined
from harness.models.sdf.errors import SdfWarning
from harness.models.sdf.materials import collada_appearance

__all__ = ["COLLISION_GROUP", "SpanningTree", "build_spec", "spanning_tree"]


def _pos_quat(pose: Pose) -> tuple[list[float], list[float]]:
    return list(pose.xyz), list(pose.quat)


class SpanningTree(NamedTuple):
    """How links become bodies: placement ``order``, ``parent`` link (or ``"world"``) of each
    link, the ``joints`` into each link's body, and the ``loops`` (joints closing a loop)."""

    order: list[str]
    parent: dict[str, str]
    joints: dict[str, list[Joint]]
    loops: list[Joint]


def spanning_tree(model: RobotModel) -> SpanningTree:
    """The body tree of ``model``: links no joint has as child are roots (welded to the
    world); then each joint whose parent is placed places its child; if links remain (a loop
    with no root), the first of them in declaration order becomes a root too."""
    links = {link.name for link in model.links}
    for joint in model.joints:
        if joint.child not in links:
            raise ModelStructureError(
                f"robot {model.name!r}: joint {joint.name!r} has unknown child link {joint.child!r}"
            )
        if joint.parent != "world" and joint.parent not in links:
            raise ModelStructureError(
                f"robot {model.name!r}: joint {joint.name!r} has unknown parent link "
                f"{joint.parent!r}"
            )
    children = {j.child for j in model.joints}
    tree = SpanningTree([], {}, {}, [])
    used: set[str] = set()

    def add_root(name: str) -> None:
        tree.order.append(name)
        tree.parent[name] = "world"
        tree.joints[name] = []

    for link in model.links:
        if link.name not in children:
            add_root(link.name)
    while True:
        progress = True
        while progress:
            progress = False
            for joint in model.joints:
                if joint.name in used or joint.child in tree.parent:
                    continue
                if joint.parent == "world" or joint.parent in tree.parent:
                    group = [
                        j
                        for j in model.joints
                        if j.parent == joint.parent
                        and j.child == joint.child
                        and j.name not in used
                    ]
                    used.update(j.name for j in group)
                    tree.order.append(joint.child)
                    tree.parent[joint.child] = joint.parent
                    tree.joints[joint.child] = group
                    progress = True
        missing = [link.name for link in model.links if link.name not in tree.parent]
        if not missing:
            break
        add_root(missing[0])
    tree.loops.extend(j for j in model.joints if j.name not in used)
    return tree


def _add_joint(body: mujoco.MjsBody, joint: Joint, link_pose: Pose, parent: str) -> None:
    local = link_pose.inverse()
    pos = list(local.transform_point(joint.pose.xyz))
    axis = list(local.rotate(joint.axis)) if any(joint.axis) else [0.0, 0.0, 1.0]
    kind = joint.type
    if kind == "fixed":
        return
    if kind == "floating":
        if parent != "world":
            raise ModelStructureError(
                f"joint {joint.name!r}: a floating joint must connect to the world, not {parent!r}"
            )
        body.add_freejoint(name=joint.name)
        return
    if kind == "ball":
        body.add_joint(name=joint.name, type=mujoco.mjtJoint.mjJNT_BALL, pos=pos)
        return
    if kind == "planar":
        normal = np.asarray(axis)
        u = np.cross(normal, [1.0, 0.0, 0.0])
        if np.linalg.norm(u) < 1e-6:
            u = np.cross(normal, [0.0, 1.0, 0.0])
        u = u / np.linalg.norm(u)
        v = np.cross(normal, u)
        for suffix, direction in (("::x", u), ("::y", v)):
            body.add_joint(
                name=joint.name + suffix,
                type=mujoco.mjtJoint.mjJNT_SLIDE,
                pos=pos,
                axis=list(direction),
            )
        body.add_joint(name=joint.name, type=mujoco.mjtJoint.mjJNT_HINGE, pos=pos, axis=axis)
        return
    if kind == "screw":
        warnings.warn(
            SdfWarning(
                f"joint {joint.name!r}: screw joint built as a hinge without translation "
                "(RobotModel carries no thread pitch)"
            ),
            stacklevel=3,
        )
    mj_type = mujoco.mjtJoint.mjJNT_SLIDE if kind == "prismatic" else mujoco.mjtJoint.mjJNT_HINGE
    added = body.add_joint(name=joint.name, type=mj_type, pos=pos, axis=axis)
    lower, upper = joint.limits.lower, joint.limits.upper
    if kind != "continuous" and lower is not None and upper is not None:
        added.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        added.range = [lower, upper]
    damping = np.zeros(len(np.atleast_1d(added.damping)))
    damping[0] = joint.damping
    added.damping = damping if damping.size > 1 else float(damping[0])
    added.frictionloss = joint.friction


def _geom_size(geometry: Geometry, where: str) -> list[float]:
    size = geometry.size
    if geometry.kind == "box":
        return [s / 2 for s in size]
    if geometry.kind in ("cylinder", "capsule"):
        return [size[0], size[1] / 2, 0.0]
    if geometry.kind == "sphere":
        return [size[0], 0.0, 0.0]
    if geometry.kind == "ellipsoid":
        return list(size)
    if geometry.kind == "plane":
        return [size[0] / 2, size[1] / 2, 1.0] if len(size) == 2 else [0.0, 0.0, 1.0]
    raise ModelStructureError(f"{where}: geometry {geometry.kind!r} has no MuJoCo size")


_GEOM_TYPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    "plane": mujoco.mjtGeom.mjGEOM_PLANE,
    "mesh": mujoco.mjtGeom.mjGEOM_MESH,
}


def _add_geom(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    link: Link,
    shape: Shape,
    visual: bool,
    assets: dict[str, bytes],
    cache_dir: str | Path | None,
) -> mujoco.MjsGeom:
    """Add the geom of ``shape``; a mesh's file goes into ``assets`` (name -> bytes)."""
    name = f"{link.name}/{shape.name}"
    if visual and spec.geom(name) is not None:  # a visual named like a collision
        name = f"{link.name}/visual:{shape.name}"
    where = f"link {link.name!r} {'visual' if visual else 'collision'} {shape.name!r}"
    pos, quat = _pos_quat(link.pose.inverse() * shape.pose)
    geometry = shape.geometry
    geom = body.add_geom(name=name, type=_GEOM_TYPES[geometry.kind], pos=pos, quat=quat)
    if geometry.kind == "mesh":
        path = geometry.mesh_path or ""
        check_confined(path, path, context=where, what="mesh")
        if not Path(path).is_file():
            raise ModelStructureError(f"{where}: mesh not found: {path!r}")
        mesh_name = f"mesh:{name}"
        asset = mesh_asset(path, cache_dir=cache_dir, context=where)
        assets[asset.name] = asset.data
        spec.add_mesh(name=mesh_name, file=asset.name, scale=list(geometry.mesh_scale))
        geom.meshname = mesh_name
    else:
        geom.size = _geom_size(geometry, where)
    if visual:
        geom.contype = 0
        geom.conaffinity = 0
        geom.group = 1
        geom.density = 0.0
        appearance = shape.appearance
        if appearance is None and geometry.kind == "mesh":  # drawn in its own material
            appearance = collada_appearance(geometry.mesh_path or "")
        if appearance is not None:
            _add_material(spec, geom, appearance, assets, where)
    return geom


COLLISION_GROUP = 3
"""The geom group of collision geoms in a model built with its visuals: cameras draw groups
0-2, so they see the visuals only, as Gazebo's cameras do."""


def _add_material(
    spec: mujoco.MjSpec,
    geom: mujoco.MjsGeom,
    appearance: Appearance,
    assets: dict[str, bytes],
    where: str,
) -> None:
    """A material for ``appearance`` (named by geom), with its texture (named by content)."""
    material = spec.add_material(
        name=f"material:{geom.name}",
        rgba=list(appearance.rgba),
        emission=appearance.emission,
        specular=appearance.specular,
        shininess=appearance.shininess,
    )
    if appearance.texture is not None:
        try:
            data = Path(appearance.texture).read_bytes()
        except OSError as exc:
            raise ResolveError(
                f"{where}: cannot read texture {appearance.texture!r}: {exc.strerror}"
            ) from None
        name = asset_name(appearance.texture, data)
        if name not in assets:
            assets[name] = data
            spec.add_texture(name=f"texture:{name}", type=mujoco.mjtTexture.mjTEXTURE_2D, file=name)
        textures = list(material.textures)
        textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = f"texture:{name}"
        material.textures = textures
    geom.material = material.name


def _add_inertial(body: mujoco.MjsBody, link: Link, welded: bool) -> None:
    """The link's ``<inertial>``. A link welded to the world (a static model's) never moves:
    its inertia has no effect and is not judged (Gazebo ignores it), so a tensor MuJoCo would
    refuse is handed over as valid principal moments instead."""
    inertial = link.inertial
    if inertial is None or inertial.mass == 0.0:
        return  # massless (static or welded) link: MuJoCo names it if it moves
    if welded and not (math.isfinite(inertial.mass) and inertial.mass > 0.0):
        return
    local = link.pose.inverse() * inertial.pose
    ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    rot = local.rotation_matrix()
    in_body = rot @ tensor @ rot.T
    body.explicitinertial = True
    body.mass = inertial.mass
    body.ipos = list(local.xyz)
    principal = principal_on_edge(in_body, welded=welded)
    if principal is not None:
        body.inertia, body.iquat = principal
        return
    body.fullinertia = [
        in_body[0, 0],
        in_body[1, 1],
        in_body[2, 2],
        in_body[0, 1],
        in_body[0, 2],
        in_body[1, 2],
    ]


def _add_loop(spec: mujoco.MjSpec, joint: Joint, parent_pose: Pose) -> None:
    local = parent_pose.inverse()
    anchor = np.asarray(local.transform_point(joint.pose.xyz))
    if joint.type == "fixed":
        eq = spec.add_equality(name=joint.name, type=mujoco.mjtEq.mjEQ_WELD)
        eq.objtype = mujoco.mjtObj.mjOBJ_BODY
        eq.name1, eq.name2 = joint.parent, joint.child
        return
    anchors: list[np.ndarray]
    if joint.type == "ball":
        anchors = [anchor]
    elif joint.type in ("revolute", "continuous"):
        axis = np.asarray(local.rotate(joint.axis))
        anchors = [anchor, anchor + 0.1 * axis]
    else:
        raise ModelStructureError(
            f"joint {joint.name!r}: a {joint.type} joint cannot close a kinematic loop "
            "(only fixed, ball, revolute, continuous)"
        )
    for index, point in enumerate(anchors):
        eq = spec.add_equality(
            name=joint.name if index == 0 else f"{joint.name}::axis_point",
            type=mujoco.mjtEq.mjEQ_CONNECT,
        )
        eq.objtype = mujoco.mjtObj.mjOBJ_BODY
        eq.name1, eq.name2 = joint.parent, joint.child
        data = np.array(eq.data)
        data[0:3] = point
        eq.data = data


def _unresolved(shape: Shape) -> bool:
    """A mesh whose reference did not resolve (kept as written: a URI or a relative path;
    decided on the text, nothing looked up). Gazebo draws the model without it."""
    path = shape.geometry.mesh_path or ""
    return shape.geometry.kind == "mesh" and ("://" in path or not Path(path).is_absolute())


def build_spec(
    model: RobotModel, *, visuals: bool = False, cache_dir: str | Path | None = None
) -> mujoco.MjSpec:
    """The bodies, joints, inertials, collision geoms (and, with ``visuals``, visual geoms
    that do not collide, group 1, with their materials, the collision geoms then in group
    :data:`COLLISION_GROUP`) and loop/mimic equalities of ``model``; the worldbody is the
    model frame. Actuators and the scene are the caller's.

    Meshes are in ``spec.assets`` under content-derived names (see
    :mod:`harness.models.files.assets`): the spec does not depend on where the files are.
    ``cache_dir``: the converted-mesh cache (see :mod:`harness.models.files.meshes`)."""
    spec = mujoco.MjSpec()
    spec.modelname = model.name or "robot"
    spec.compiler.degree = False
    tree = spanning_tree(model)
    links = {link.name: link for link in model.links}
    bodies: dict[str, mujoco.MjsBody] = {"world": spec.worldbody}
    welded: dict[str, bool] = {}
    assets: dict[str, bytes] = {}
    missing: list[str] = []
    for name in tree.order:
        link = links[name]
        parent = tree.parent[name]
        parent_pose = links[parent].pose if parent != "world" else Pose()
        pos, quat = _pos_quat(parent_pose.inverse() * link.pose)
        body = bodies[parent].add_body(name=name, pos=pos, quat=quat)
        bodies[name] = body
        for joint in tree.joints[name]:
            _add_joint(body, joint, link.pose, parent)
        welded[name] = (parent == "world" or welded[parent]) and all(
            j.type == "fixed" for j in tree.joints[name]
        )
        _add_inertial(body, link, welded[name])
        for shape in link.collisions:
            geom = _add_geom(spec, body, link, shape, False, assets, cache_dir)
            if visuals:
                geom.group = COLLISION_GROUP
        if visuals:
            for shape in link.visuals:
                if _unresolved(shape):
                    missing.append(f"{name}/{shape.name} ({shape.geometry.mesh_path})")
                    continue
                _add_geom(spec, body, link, shape, True, assets, cache_dir)
    if missing:
        warnings.warn(
            f"{model.source or model.name}: {len(missing)} visual mesh(es) not found, left out "
            f"(cameras do not see them): {', '.join(missing[:3])}"
            f"{', ...' if len(missing) > 3 else ''}",
            SdfWarning,
            stacklevel=2,
        )
    if assets:
        spec.assets = assets
    for joint in tree.loops:
        parent_pose = links[joint.parent].pose if joint.parent != "world" else Pose()
        _add_loop(spec, joint, parent_pose)
    for joint in model.joints:
        if joint.mimic is not None:
            eq = spec.add_equality(name=f"mimic:{joint.name}", type=mujoco.mjtEq.mjEQ_JOINT)
            eq.objtype = mujoco.mjtObj.mjOBJ_JOINT
            eq.name1, eq.name2 = joint.name, joint.mimic.joint
            data = np.zeros(len(eq.data))
            data[0], data[1] = joint.mimic.offset, joint.mimic.multiplier
            eq.data = data
    return spec
