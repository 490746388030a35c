"""The text a robot publishes on ``robot_description``: URDF whenever the robot can be said in
URDF.

A URDF robot publishes its source. An MJCF or SDF robot publishes a URDF written from its
description (:func:`urdf_of`), so that URDF consumers (Foxglove's 3D panel,
robot_state_publisher, MoveIt) understand it; link frames are the description's (the frames
``/tf`` carries). What URDF cannot say keeps the source text: more than one root link, a ball
or screw joint, a joint whose frame is not its child link's frame (a revolute axis not
through the child's origin). Shapes URDF has no element for (ellipsoid, plane, meshes without
a file) are left out of the visuals and collisions; capsules become cylinders of their full
length.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from harness.models.description import Geometry, Joint, Link, Pose, RobotModel, Shape

__all__ = ["description_text", "urdf_of"]

_TOLERANCE = 1e-9
_WORLD = "world"
_URDF_TYPES = {"revolute", "continuous", "prismatic", "fixed", "floating", "planar"}


def _num(value: float) -> str:
    return repr(float(value)) if value != 0 else "0"


def _origin(pose: Pose) -> str:
    xyz = " ".join(_num(v) for v in pose.xyz)
    rpy = " ".join(_num(v) for v in pose.rpy())
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _geometry(geometry: Geometry) -> str | None:
    kind, size = geometry.kind, geometry.size
    if kind == "box" and len(size) == 3:
        return f'<box size="{" ".join(_num(v) for v in size)}"/>'
    if kind in ("cylinder", "capsule") and len(size) == 2:
        radius, length = size
        if kind == "capsule":
            length += 2 * radius
        return f'<cylinder radius="{_num(radius)}" length="{_num(length)}"/>'
    if kind == "sphere" and len(size) == 1:
        return f'<sphere radius="{_num(size[0])}"/>'
    if kind == "mesh" and geometry.mesh_path:
        scale = " ".join(_num(v) for v in geometry.mesh_scale)
        return f'<mesh filename={quoteattr(geometry.mesh_path)} scale="{scale}"/>'
    return None


def _shapes(tag: str, link: Link, shapes: tuple[Shape, ...]) -> list[str]:
    out = []
    inverse = link.pose.inverse()
    for shape in shapes:
        geometry = _geometry(shape.geometry)
        if geometry is not None:
            out.append(
                f"    <{tag}>{_origin(inverse * shape.pose)}<geometry>{geometry}</geometry></{tag}>"
            )
    return out


def _link(link: Link) -> str:
    lines = [f"  <link name={quoteattr(link.name)}>"]
    inertial = link.inertial
    if inertial is not None:
        ixx, ixy, ixz, iyy, iyz, izz = inertial.inertia
        lines.append(
            f"    <inertial>{_origin(link.pose.inverse() * inertial.pose)}"
            f'<mass value="{_num(inertial.mass)}"/><inertia ixx="{_num(ixx)}" '
            f'ixy="{_num(ixy)}" ixz="{_num(ixz)}" iyy="{_num(iyy)}" iyz="{_num(iyz)}" '
            f'izz="{_num(izz)}"/></inertial>'
        )
    lines += _shapes("visual", link, link.visuals)
    lines += _shapes("collision", link, link.collisions)
    lines.append("  </link>")
    return "\n".join(lines)


def urdf_of(model: RobotModel) -> str | None:
    """``model`` as URDF text, or ``None`` when URDF cannot express it (see the module
    docstring)."""
    links = {link.name: link for link in model.links}
    model_joints = list(model.joints)
    children = {j.child for j in model_joints}
    roots = [name for name in links if name not in children]
    if len(children) != len(model_joints):
        return None  # a link with two parents: not a tree
    if len(roots) != 1 or any(j.parent not in links for j in model_joints):
        # Several roots, or joints to the world: one "world" link holds them (the frame the
        # session's /tf hangs everything from), roots attached to it where they are.
        if any(j.parent not in links and j.parent != _WORLD for j in model_joints):
            return None
        if _WORLD not in links:
            links = {_WORLD: Link(_WORLD, Pose()), **links}
        for root in roots:
            if root != _WORLD and root not in children:
                model_joints.append(
                    Joint(f"{_WORLD}_to_{root}", "fixed", _WORLD, root, links[root].pose)
                )
    joints = []
    for j in model_joints:
        if j.type not in _URDF_TYPES or j.parent not in links or j.child not in links:
            return None
        parent, child = links[j.parent].pose, links[j.child].pose
        axis = np.asarray(j.axis, dtype=float)
        if j.type in ("revolute", "continuous"):
            offset = np.asarray(child.xyz) - np.asarray(j.pose.xyz)
            if np.linalg.norm(np.cross(offset, axis)) > _TOLERANCE * max(
                1.0, float(np.linalg.norm(offset))
            ):
                return None  # the axis does not pass through the child's origin
        lines = [
            f"  <joint name={quoteattr(j.name)} type={quoteattr(j.type)}>",
            f"    <parent link={quoteattr(j.parent)}/><child link={quoteattr(j.child)}/>",
            f"    {_origin(parent.inverse() * child)}",
        ]
        if j.type in ("revolute", "continuous", "prismatic", "planar") and np.any(axis):
            local = child.inverse().rotate(axis.tolist())
            lines.append(f'    <axis xyz="{" ".join(_num(v) for v in local)}"/>')
        limits = j.limits
        if j.type in ("revolute", "prismatic"):
            lower = limits.lower if limits.lower is not None else -math.inf
            upper = limits.upper if limits.upper is not None else math.inf
            if not (math.isfinite(lower) and math.isfinite(upper)):
                lower, upper = -math.pi, math.pi  # URDF requires both; MJCF may give none
            attrs: dict[str, Any] = {
                "lower": lower,
                "upper": upper,
                "effort": limits.effort if limits.effort is not None else 0.0,
                "velocity": limits.velocity if limits.velocity is not None else 0.0,
            }
            lines.append(
                "    <limit " + " ".join(f'{k}="{_num(v)}"' for k, v in attrs.items()) + "/>"
            )
        if j.mimic is not None:
            lines.append(
                f"    <mimic joint={quoteattr(j.mimic.joint)} "
                f'multiplier="{_num(j.mimic.multiplier)}" offset="{_num(j.mimic.offset)}"/>'
            )
        lines.append("  </joint>")
        joints.append("\n".join(lines))
    body = [_link(links[name]) for name in links] + joints
    return (
        f'<?xml version="1.0"?>\n<robot name={quoteattr(model.name)}>\n'
        + "\n".join(body)
        + "\n</robot>\n"
    )


def description_text(description: RobotModel, sources: Mapping[str, bytes], fallback: str) -> str:
    """What ``robot_description`` carries: the URDF source of a URDF robot, a URDF written
    from the description of any other (:func:`urdf_of`), else the source (or ``fallback``,
    the compiled MJCF, without one)."""
    source = next(
        (blob.decode("utf-8", errors="replace") for name, blob in sources.items()
         if name.startswith("model/")),
        fallback,
    )  # fmt: skip
    if description.format == "urdf":
        return source
    written = urdf_of(description)
    return written if written is not None else source
