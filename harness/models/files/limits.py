"""Resource limits of a model, checked before MuJoCo compiles it (or builds its data).

A robot file, a scenario's map or a recording's model attachment may come from elsewhere; a
174-byte MJCF ``<size nuser_body="100000000" nuserdata="1000000000">`` asks the compiler for
tens of GB, and a URDF chain 100,000 links deep crashes MuJoCo's reader. What a model
declares is checked here first and refused with one :class:`ModelLimitError` line naming the
file, the quantity and the limit:

- ``<size>``: user data per element (``nuser_*``), ``nuserdata``, ``nkey``, the arena
  (``memory``), ``nstack``, ``njmax``/``nconmax``;
- counts: bodies, joints, geoms; the depth of the body tree (MuJoCo's compiler refuses more
  than 1,024 levels, its readers recurse per level, and a chain of hinges has a dense mass
  matrix whose cost grows with the cube of its depth: 500 levels compile in about a second,
  1,000 in ten);
- meshes: vertices declared inline and in the mesh files (STL, OBJ headers and lines).

:data:`LIMITS` holds the defaults; they are far above any robot the harness is for (a
humanoid has ~40 bodies) and far below what exhausts a shared machine.

A xacro file is checked while it expands, not after (:class:`XacroLimits`): 2 KB of macros
that double at each of 22 levels ask for 4 million elements, and xacro's DOM makes the work
grow faster than the output. The expansion counts the elements it processes, the ``${...}``
expressions it evaluates, the text it produces (evaluated attribute values and text, tag and
attribute names, comments: an upper bound of the output's size), the sibling-list scans its
DOM edits cost, how deep elements and macro calls nest, and its time, and stops at the first
count over its limit with one :class:`ModelLimitError` line. The real robots of
``tests/data`` (UR, Franka's arms with their hand, two of them on one base, a Clearpath base)
process at most 1,300 elements, 2,000 expressions, 210 KB of text and 200,000 sibling scans,
nested 15 deep: the defaults are 35 times that or more (the nesting 6 times).
``HARNESS_MAX_XACRO_*`` environment variables change them (:func:`xacro_limits`).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import mujoco

from harness.models.description import RobotModel
from harness.models.errors import ModelError

__all__ = [
    "LIMITS",
    "XACRO_LIMITS",
    "XACRO_LIMIT_ENV",
    "ModelLimitError",
    "ModelLimits",
    "XacroLimits",
    "check_description",
    "check_model_limits",
    "check_spec",
    "check_urdf_counts",
    "xacro_limits",
]


class ModelLimitError(ModelError):
    """A model declares more than a resource limit allows."""


@dataclass(frozen=True, slots=True)
class ModelLimits:
    """The most a model may declare (see the module docstring)."""

    bodies: int = 10_000
    joints: int = 10_000
    geoms: int = 100_000
    tree_depth: int = 500
    user_per_element: int = 1_000
    userdata: int = 10_000_000
    keys: int = 10_000
    memory_bytes: int = 4 * 2**30
    constraints: int = 1_000_000
    mesh_vertices: int = 20_000_000


LIMITS = ModelLimits()


@dataclass(frozen=True, slots=True)
class XacroLimits:
    """The most one xacro expansion may do, counted while it runs (see the module docstring).

    - ``elements``: elements processed (each output element once, plus macro calls, bodies
      and blocks on their way);
    - ``expressions``: ``${...}`` expressions evaluated;
    - ``text_bytes``: characters of text produced, counted as they are made (the output's
      size bounded from above): the limit for XML files read;
    - ``dom_work``: sibling-list entries scanned by DOM edits (moving a macro's expansion
      into its parent scans the parent's children: the cost that grows fastest);
    - ``depth``: elements and macro calls nested inside each other;
    - ``seconds``: wall time, the last guard (one ``${...}`` expression runs to its end).
    """

    elements: int = 50_000
    expressions: int = 500_000
    text_bytes: int = 32 * 2**20
    dom_work: int = 50_000_000
    depth: int = 100
    seconds: float = 60.0


XACRO_LIMITS = XacroLimits()

XACRO_LIMIT_ENV = {
    "elements": "HARNESS_MAX_XACRO_ELEMENTS",
    "expressions": "HARNESS_MAX_XACRO_EXPRESSIONS",
    "text_bytes": "HARNESS_MAX_XACRO_TEXT_BYTES",
    "dom_work": "HARNESS_MAX_XACRO_DOM_WORK",
    "depth": "HARNESS_MAX_XACRO_DEPTH",
    "seconds": "HARNESS_MAX_XACRO_SECONDS",
}
"""The environment variable that changes each :class:`XacroLimits` field."""


def xacro_limits() -> XacroLimits:
    """The xacro limits in force: :data:`XACRO_LIMITS`, with each field an environment
    variable of :data:`XACRO_LIMIT_ENV` sets replaced (a positive number, else one
    :class:`ModelLimitError` line naming the variable)."""
    values: dict[str, float] = {}
    for item in fields(XacroLimits):
        name = XACRO_LIMIT_ENV[item.name]
        text = os.environ.get(name, "").strip()
        if not text:
            continue
        try:
            value = float(text) if item.name == "seconds" else int(text)
        except ValueError:
            value = -1
        if not value > 0:
            raise ModelLimitError(f"{name}={text!r}: expected a positive number")
        values[item.name] = value
    return XacroLimits(**values) if values else XACRO_LIMITS  # type: ignore[arg-type]


_USER_SIZES = (
    "nuser_body",
    "nuser_jnt",
    "nuser_geom",
    "nuser_site",
    "nuser_cam",
    "nuser_tendon",
    "nuser_actuator",
    "nuser_sensor",
)


def _over(source: str, what: str, value: int, limit: int) -> None:
    if value > limit:
        raise ModelLimitError(
            f"{source}: {what} is {value}, over the limit of {limit} (a model this large "
            "would exhaust memory or crash MuJoCo)"
        )


def _depth(parents: Mapping[Any, Any]) -> tuple[int, Any]:
    """The deepest chain of ``child -> parent`` links (iterative: chains may be 100,000
    long) and the name at its bottom."""
    depth: dict[Any, int] = {}
    best = 0
    deepest: Any = None
    for start in parents:
        chain = []
        name: Any = start
        while name is not None and name not in depth:
            chain.append(name)
            name = parents.get(name)
            if len(chain) > len(parents) + 1:
                break  # a cycle: the description's own check names it
        level = depth.get(name, 0) if name is not None else 0
        for item in reversed(chain):
            level += 1
            depth[item] = level
        if depth.get(start, 0) > best:
            best, deepest = depth[start], start
    return best, deepest


def check_urdf_counts(root: Any, source: str, limits: ModelLimits = LIMITS) -> None:
    """Links and joints of a parsed URDF (an lxml root), counted before it is read."""
    _over(source, "the number of links", sum(1 for _ in root.iterchildren("link")), limits.bodies)
    _over(source, "the number of joints", sum(1 for _ in root.iterchildren("joint")), limits.joints)


def check_description(model: RobotModel, source: str, limits: ModelLimits = LIMITS) -> None:
    """Links, joints and tree depth of a URDF/SDF description, before MuJoCo reads it."""
    _over(source, "the number of links", len(model.links), limits.bodies)
    _over(source, "the number of joints", len(model.joints), limits.joints)
    parents = {joint.child: joint.parent for joint in model.joints}
    depth, deepest = _depth(parents)
    if depth > limits.tree_depth:
        where = f"the depth of the link tree (at link {deepest!r})"
        _over(source, where, depth, limits.tree_depth)


def _count_mesh_vertices(data: bytes, name: str) -> int:
    lower = name.lower()
    if lower.endswith(".stl") and len(data) >= 84:
        (triangles,) = struct.unpack_from("<I", data, 80)
        if len(data) == 84 + 50 * int(triangles):  # binary STL
            return 3 * int(triangles)
    if lower.endswith(".stl"):
        return data.count(b"vertex")
    if lower.endswith(".obj"):
        return data.count(b"\nv ") + int(data.startswith(b"v "))
    if lower.endswith(".msh") and len(data) >= 4:
        return int(struct.unpack_from("<i", data, 0)[0])
    return 0


def _mesh_vertices(spec: mujoco.MjSpec, assets: Mapping[str, bytes]) -> int:
    total = 0
    for mesh in spec.meshes:
        total += len(mesh.uservert) // 3
        if mesh.file in assets:
            total += _count_mesh_vertices(assets[mesh.file], str(mesh.file))
    return total


def _walk(spec: mujoco.MjSpec) -> tuple[int, int, int, int, str]:
    """Bodies (world excluded), joints, geoms, tree depth and the deepest body's name, in one
    pass (the spec's own ``bodies``/``joints``/``geoms`` lists cost far more per call)."""
    bodies = joints = geoms = 0
    depth, deepest = 0, ""
    stack: list[tuple[Any, int]] = [(spec.worldbody, 0)]
    while stack:
        body, level = stack.pop()
        if level:
            bodies += 1
            if level > depth:
                depth, deepest = level, str(body.name)
        joints += len(body.joints)
        geoms += len(body.geoms)
        stack.extend((child, level + 1) for child in body.bodies)
    return bodies, joints, geoms, depth, deepest


def check_spec(spec: mujoco.MjSpec, source: str, limits: ModelLimits = LIMITS) -> None:
    """``<size>`` declarations, element counts, tree depth and mesh vertices of ``spec``,
    before :meth:`mujoco.MjSpec.compile` allocates for them."""
    for name in _USER_SIZES:
        _over(source, f"<size {name}>", int(getattr(spec, name)), limits.user_per_element)
    _over(source, "<size nuserdata>", int(spec.nuserdata), limits.userdata)
    _over(source, "<size nkey>", int(spec.nkey), limits.keys)
    _over(source, "<size memory> (bytes)", int(spec.memory), limits.memory_bytes)
    _over(source, "<size nstack>", int(spec.nstack), limits.memory_bytes // 8)
    _over(source, "<size njmax>", int(spec.njmax), limits.constraints)
    _over(source, "<size nconmax>", int(spec.nconmax), limits.constraints)
    bodies, joints, geoms, depth, deepest = _walk(spec)
    _over(source, "the number of bodies", bodies, limits.bodies)
    _over(source, "the number of joints", joints, limits.joints)
    _over(source, "the number of geoms", geoms, limits.geoms)
    if depth > limits.tree_depth:
        where = f"the depth of the body tree (at body {deepest!r})"
        _over(source, where, depth, limits.tree_depth)
    assets = dict(spec.assets)
    _over(source, "the number of mesh vertices", _mesh_vertices(spec, assets), limits.mesh_vertices)


def check_model_limits(model: mujoco.MjModel, source: str, limits: ModelLimits = LIMITS) -> None:
    """What a compiled model (a recording's ``model.mjb``) asks of its :class:`MjData`."""
    _over(source, "nuserdata", int(model.nuserdata), limits.userdata)
    _over(source, "the arena (bytes)", int(model.narena), limits.memory_bytes)
    _over(source, "the number of bodies", int(model.nbody), limits.bodies + 1)
