""":func:`load_world`: robots, primitive objects and a scene into one compiled MuJoCo world,
and the per-robot view of it (:class:`~harness.models.world.records.LoadedRobotView`).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np

from harness.models.build import setup
from harness.models.build.actuators import (
    add_actuators,
    existing_control,
    held_inertias,
    resolve_control,
)
from harness.models.build.compiler import (
    compile_lenient,
    compile_spec,
    mujoco_message,
    mujoco_warnings,
    spec_from_file,
)
from harness.models.build.decompose import MeshCollision, check_mesh_collision, decompose_spec
from harness.models.build.drive_plugins import plugin_modes
from harness.models.build.passive import drop_passive
from harness.models.build.robot import RobotBuild, dof_span, qpos_span
from harness.models.bundled import SCENES
from harness.models.description import ControlMode, Pose, RobotModel
from harness.models.errors import CompileError, ModelStructureError
from harness.models.files.assets import embed_files
from harness.models.files.resolve import resolve_uri
from harness.models.files.xmlsafe import describe, read_xml_file
from harness.models.urdf.reader import REPAIR_BOUNDINERTIA, REPAIR_BOUNDMASS
from harness.models.urdf.source import control_defaults
from harness.models.world.keyframes import combine_keyframes
from harness.models.world.records import (
    DuplicateNamespaceError,
    JointAddress,
    LoadedRobotView,
    LoadedWorld,
    RobotSpec,
    WorldObject,
    add_object,
    check_namespace,
    placement_pose,
)

__all__ = [
    "FinishedWorld",
    "StagedWorld",
    "finish_world",
    "home_positions",
    "load_world",
    "stage_world",
]


def load_world(
    robots: Sequence[RobotSpec],
    *,
    scene: str | Path | None = None,
    objects: Sequence[WorldObject] = (),
    timestep: float | None = None,
    cache_dir: str | Path | None = None,
    mesh_collision: MeshCollision = "decompose",
) -> LoadedWorld:
    """Load several robots (and primitive ``objects``) into one world and compile it.

    Each robot is built as :func:`load_robot` builds it and attached at its ``pose`` with
    the prefix ``"<namespace>/"`` on every name it brings (a namespace of None takes the
    robot's own name; ``""`` keeps names as they are). Robots are separate kinematic trees:
    their links can collide with each other (bases fixed to the world never do).
    ``scene``: as for :func:`load_robot`; None gives the ``"table"`` when the first robot is
    the demo, a lone MJCF robot in the empty namespace its own world, else ``"floor"``.
    ``objects`` are added to the world body before the robots (free objects come first in
    ``qpos``, after the scene's). ``timestep`` overrides the scene's (the servo gains are
    tuned for it). ``mesh_collision``: ``"decompose"`` (default: a non-convex colliding mesh
    of the scene or of a robot's link collides as convex pieces within 2 cm of its
    triangles) or ``"hull"`` (as its convex hull); see :mod:`harness.models.build.decompose`.

    Keyframes combine: each key name any robot has becomes one key whose robot part is that
    robot's key of that name (else its ``home``, else its zero configuration), whose rest is
    the scene's key of that name (else the model's default), with position servo targets at
    their joint's position; ``initial_positions`` override a robot's part of ``home``.
    Keys keep qpos, qvel (of a robot's own MJCF keys), ctrl and time, not act or mocap.
    Errors: :class:`DuplicateNamespaceError`, :class:`InvalidNamespaceError` and the other
    :class:`ModelError` of :func:`load_robot`, naming ``robots[i]``.
    """
    return finish_world(
        stage_world(robots, scene, objects, timestep, cache_dir, mesh_collision)
    ).world


@dataclass
class StagedWorld:
    """A world up to its first compile (what :func:`load_world` reads and attaches): the
    ``spec`` with the robots attached (each at its ``frame``), the robots being built
    (``prepared``) with their ``placements``, and what the rest of the load needs."""

    spec: mujoco.MjSpec
    prepared: list[RobotBuild]
    placements: list[Pose | None]
    several: bool
    world_source: str
    sources: dict[str, bytes]
    mesh_collision: MeshCollision
    own_world: bool


@dataclass
class FinishedWorld:
    """A world :func:`finish_world` compiled: the :class:`LoadedWorld`, the first compile
    the servo gains, placement and keyframes were derived from (``first``), the robots as
    built (``prepared``) and their placements on the floor."""

    world: LoadedWorld
    first: mujoco.MjModel
    prepared: list[RobotBuild]
    placements: list[Pose | None]
    several: bool
    sources: dict[str, bytes]


def stage_world(
    robots: Sequence[RobotSpec],
    scene: str | Path | None,
    objects: Sequence[WorldObject],
    timestep: float | None,
    cache_dir: str | Path | None,
    mesh_collision: MeshCollision,
) -> StagedWorld:
    """The first part of :func:`load_world`: every robot read and built, the scene read, the
    objects added and the robots attached (nothing compiled yet)."""
    if not robots:
        raise ModelStructureError("load_world: no robots given")
    mesh_collision = check_mesh_collision(mesh_collision, "load_world")
    several = len(robots) > 1
    decomposed: dict[str, bytes] = {}  # the cached pieces used: sources a rebuild reads
    prepared: list[RobotBuild] = []
    namespaces: dict[str, int] = {}
    for index, request in enumerate(robots):
        robot = RobotBuild(index, request, cache_dir)
        # a link's concave collision mesh as a fixture's (an arena as a URDF): convex pieces
        # in the link's body, massless, collision only (a cold load decomposes the meshes in
        # parallel processes, after one warning; later loads read the cache)
        decomposed.update(
            decompose_spec(
                robot.spec, mode=mesh_collision, source=robot.source, cache_dir=cache_dir
            )
        )
        where = robot.where(several)
        if request.namespace is None:
            namespace = check_namespace(robot.description.name, where)
        else:
            namespace = check_namespace(request.namespace, where)
        if namespace in namespaces:
            raise DuplicateNamespaceError(
                f"{where}: namespace {namespace!r} is already robots[{namespaces[namespace]}]'s "
                "(give each robot its own namespace)"
            )
        namespaces[namespace] = index
        robot.set_namespace(namespace)
        prepared.append(robot)
    placements = [placement_pose(r.request.pose, r.where(several)) for r in prepared]
    first_robot = prepared[0]
    world_source = first_robot.source if not several else f"world [{', '.join(namespaces)}]"

    sources: dict[str, bytes] = {}
    for robot in prepared:
        sources[f"model/{robot.prefix}{robot.path.name}"] = robot.model_bytes
        sources.update(_prefixed(robot.extra_sources, robot.prefix))
    if scene is None and str(first_robot.request.source) == "demo":
        scene = "table"
    own_world = scene is None and not several and first_robot.kind == "mjcf"
    own_world = own_world and first_robot.namespace == ""
    if own_world:
        spec = first_robot.spec
        if placements[0] is not None:
            _place_top_bodies(spec, placements[0])
        for number, obj in enumerate(objects):
            add_object(spec, obj, f"{world_source}: objects[{number}] ({obj.name!r})")
    else:
        visuals = any(r.request.visuals for r in prepared)  # a camera draws the world too
        spec, scene_path, scene_sources = _scene_spec(scene, world_source, cache_dir, visuals)
        decomposed.update(
            decompose_spec(spec, mode=mesh_collision, source=str(scene_path), cache_dir=cache_dir)
        )
        sources.update(scene_sources)
        for number, obj in enumerate(objects):
            add_object(spec, obj, f"{world_source}: objects[{number}] ({obj.name!r})")
        for robot, placement in zip(prepared, placements, strict=True):
            if placement is None:
                frame = spec.worldbody.add_frame()
            else:
                frame = spec.worldbody.add_frame(pos=list(placement.xyz), quat=list(placement.quat))
            robot.frame = frame
            try:
                with mujoco_warnings():
                    spec.attach(robot.spec, prefix=robot.prefix, frame=frame)
            except ValueError as exc:
                raise CompileError(
                    f"{robot.where(several)}: cannot attach the robot into the scene: "
                    f"{mujoco_message(exc)}"
                ) from None
    if timestep is not None:
        if not (math.isfinite(timestep) and timestep > 0):
            raise ModelStructureError(f"{world_source}: timestep {timestep!r} is not positive")
        spec.option.timestep = timestep
    spec.modelname = first_robot.description.name if not several else "world"
    sources.update(decomposed)
    return StagedWorld(
        spec, prepared, placements, several, world_source, sources, mesh_collision, own_world
    )


def finish_world(staged: StagedWorld) -> FinishedWorld:
    """The rest of :func:`load_world` on a staged world (changed in place): the first
    compile, each robot's control, drives, self-collision and placement on the floor derived
    from it, the combined keyframes, the final compile and the per-robot views."""
    spec, prepared, placements = staged.spec, staged.prepared, staged.placements
    several, world_source, sources = staged.several, staged.world_source, staged.sources
    mesh_collision = staged.mesh_collision
    first = compile_lenient(
        spec,
        world_source,
        strict=any(r.request.strict for r in prepared),
        notes=prepared[0].notes if prepared else [],
    )
    joint_names = {first.joint(j).name for j in range(first.njnt)}
    servo_qpos = np.array(first.qpos0, dtype=float)
    for robot in prepared:
        setup.start_within_limits(first, robot)
        robot.key_values(first, "home", servo_qpos)
    held = held_inertias(first, servo_qpos)
    for robot in prepared:
        where = robot.where(several)
        if robot.existing_actuators:
            robot.modes, robot.actuated = existing_control(first, robot.prefix, robot.description)
            continue
        own_joints = {
            name.removeprefix(robot.prefix) for name in joint_names if name.startswith(robot.prefix)
        }
        robot.modes = resolve_control(robot.description, own_joints, robot.request.control, where)
        robot.modes = control_defaults(robot.description, robot.modes, robot.request.control)
        robot.modes = plugin_modes(robot.modes, robot.plugin_wheels, robot.request.control)
        robot.modes = drop_passive(robot.modes, robot.declared_actuated, robot.request.control)
        gains = dict(robot.request.gains or {})
        unknown_gains = sorted(set(gains) - set(robot.modes))
        if unknown_gains:
            raise ModelStructureError(
                f"{where}: gains name joints that are not controllable: {unknown_gains}"
            )
        robot.actuated = add_actuators(
            spec, first, robot.description, robot.modes, gains, held, robot.prefix
        )
        setup.compensate_gravity(spec, first, robot)
    for robot in prepared:
        if robot.request.srdf is not None:
            srdf = _locate_srdf(robot.request.srdf, robot.request.packages)
            body_names = {first.body(b).name for b in range(first.nbody)}
            if robot.prefix:  # only this robot's links
                links = {link.name for link in robot.description.links}
                body_names = {n for n in links if robot.prefix + n in body_names}
            sources[f"srdf/{robot.prefix}{srdf.name}"], robot.srdf_pairs = _add_srdf_excludes(
                spec, srdf, body_names, robot.prefix
            )
    for index, robot in enumerate(prepared):
        setup.apply_self_collision(spec, first, robot, servo_qpos)
        if robot.frame is not None:
            placements[index] = setup.place_on_floor(first, robot, servo_qpos, placements[index])
    combine_keyframes(spec, first, prepared, several)

    model = compile_spec(spec, world_source, strict=any(r.request.strict for r in prepared))
    for robot in prepared:
        if robot.repair:
            robot.repairs_made = robot.source_repairs + _repairs(
                model, robot.description, robot.repaired_inertias, robot.prefix
            )
    setup.report_start(model, prepared)
    with mujoco_warnings():
        mjcf = spec.to_xml()
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    views = tuple(
        _view(model, robot, placement or Pose(), sources)
        for robot, placement in zip(prepared, placements, strict=True)
    )
    control: dict[str, ControlMode] = {}
    for view in views:
        control.update({view.mujoco_name(j): m for j, m in view.control.items()})
    actuated = tuple(
        model.joint(int(model.actuator_trnid[a][0])).name
        for a in range(model.nu)
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
    )
    world = LoadedWorld(
        name=str(spec.modelname),
        spec=spec,
        model=model,
        robots=views,
        control=MappingProxyType(control),
        actuated=actuated,
        kinematic=tuple(n for n, m in control.items() if m == "kinematic"),
        mjcf=mjcf,
        mjb=buffer.tobytes(),
        sources=MappingProxyType(sources),
        sha256=hashlib.sha256(mjcf.encode()).hexdigest(),
        mesh_collision=mesh_collision,
    )
    return FinishedWorld(world, first, prepared, placements, several, sources)


def _locate_srdf(srdf: str | Path, packages: Any) -> Path:
    """The SRDF file a robot's ``srdf`` names: a path, or ``package://pkg/path`` (a MoveIt
    config package, found like a robot's package)."""
    text = str(srdf)
    if text.startswith("package://"):
        return resolve_uri(
            text, base_dir=Path.cwd(), packages=packages, context="srdf", what="srdf"
        )
    path = Path(srdf)
    if not path.is_file():
        raise ModelStructureError(f"{path}: srdf file not found")
    return path


def _add_srdf_excludes(
    spec: mujoco.MjSpec, srdf: Path, body_names: set[str], prefix: str = ""
) -> tuple[bytes, tuple[tuple[str, str], ...]]:
    root, raw = read_xml_file(srdf)
    pairs = []
    for element in root.iter("disable_collisions"):
        link1, link2 = element.get("link1"), element.get("link2")
        for link in (link1, link2):
            if not link or link not in body_names:
                raise ModelStructureError(
                    f"{srdf}: {describe(element)}: link {link!r} is not a body of the model"
                )
        spec.add_exclude(bodyname1=prefix + str(link1), bodyname2=prefix + str(link2))
        pairs.append((str(link1), str(link2)))
    return raw, tuple(pairs)


def _scene_spec(
    scene: str | Path | None, source: str, cache_dir: str | Path | None, visuals: bool = False
) -> tuple[mujoco.MjSpec, Path, dict[str, bytes]]:
    """The scene's spec, its file and its sources (an SDF world: every file it reads; with
    ``visuals``, its visual geoms, materials and lights too)."""
    if scene is None:
        scene = "floor"
    path = SCENES.get(str(scene)) if isinstance(scene, str) else None
    if path is None:
        path = Path(scene)
        if not path.is_file():
            raise ModelStructureError(
                f"{source}: scene {str(scene)!r} is neither a file nor one of {sorted(SCENES)}"
            )
    from harness.models.sdf import worldfile  # imports the SDF reader: only when a world is used

    if worldfile.is_sdf_world(path):
        world = worldfile.load_world_file(path, cache_dir=cache_dir, visuals=visuals)
        return world.spec, path, dict(world.sources)
    read_xml_file(path)
    spec = spec_from_file(path)
    embed_files(spec, source=str(path), cache_dir=cache_dir)
    return spec, path, {f"scene/{path.name}": path.read_bytes()}


def _repairs(
    model: mujoco.MjModel,
    description: RobotModel,
    repaired_inertias: Mapping[str, tuple[float, ...]],
    prefix: str = "",
) -> tuple[str, ...]:
    """The links whose mass or inertia the compiler bounds or balancing changed."""
    found = []
    for link in description.links:
        name = prefix + link.name
        body = model.body(name) if _has_body(model, name) else None
        if body is None or body.id == 0:
            continue
        mass = float(model.body_mass[body.id])
        inertia = model.body_inertia[body.id]
        source_mass = link.inertial.mass if link.inertial else 0.0
        if mass == REPAIR_BOUNDMASS and source_mass < REPAIR_BOUNDMASS:
            found.append(
                f"{link.name}: mass {source_mass:g} -> {REPAIR_BOUNDMASS:g} kg (boundmass)"
            )
        if any(float(v) == REPAIR_BOUNDINERTIA for v in inertia):
            found.append(
                f"{link.name}: principal inertia raised to {REPAIR_BOUNDINERTIA:g} kg m^2 "
                "(boundinertia)"
            )
        elif link.inertial is not None and link.inertial.mass > 0:
            ixx, ixy, ixz, iyy, iyz, izz = repaired_inertias.get(link.name, link.inertial.inertia)
            tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            expected = np.sort(np.linalg.eigvalsh(tensor))
            actual = np.sort(np.asarray(inertia, dtype=float))
            if not np.allclose(expected, actual, rtol=1e-6, atol=1e-12):
                found.append(
                    f"{link.name}: inertia {np.round(expected, 9).tolist()} -> "
                    f"{np.round(actual, 9).tolist()} (balanceinertia)"
                )
    return tuple(found)


def _has_body(model: mujoco.MjModel, name: str) -> bool:
    return bool(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0)


def _place_top_bodies(spec: mujoco.MjSpec, pose: Pose) -> None:
    """Move every top-level body of a world-owning MJCF robot by ``pose`` (bodies in a
    ``<frame>`` move with their frame)."""
    moved: list[Any] = []
    for body in spec.worldbody.bodies:
        frame = body.frame
        target = frame if frame is not None else body
        if any(target is m for m in moved):
            continue
        moved.append(target)
        composed = pose * Pose(
            tuple(float(v) for v in target.pos),  # type: ignore[arg-type]
            tuple(float(v) for v in target.quat),  # type: ignore[arg-type]
        )
        target.pos = list(composed.xyz)
        target.quat = list(composed.quat)


def _view(
    model: mujoco.MjModel, robot: RobotBuild, placement: Pose, sources: Mapping[str, bytes]
) -> LoadedRobotView:
    joints: dict[str, JointAddress] = {}
    for j in robot.joint_ids(model):
        name = model.joint(j).name
        start, width = qpos_span(model, j)
        dof, dofs = dof_span(model, j)
        joints[name.removeprefix(robot.prefix)] = JointAddress(name, j, start, dof, width, dofs)
    by_joint = {address.id: joint for joint, address in joints.items()}
    actuators = {
        by_joint[int(model.actuator_trnid[a][0])]: a
        for a in range(model.nu)
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
        and int(model.actuator_trnid[a][0]) in by_joint
    }
    bodies = {
        link.name: int(model.body(robot.prefix + link.name).id)
        for link in robot.description.links
        if _has_body(model, robot.prefix + link.name)
    }
    home = home_positions(model, joints)
    mine = {
        f"model/{robot.prefix}{robot.path.name}",
        f"srdf/{robot.prefix}{Path(robot.request.srdf).name}" if robot.request.srdf else "",
        *_prefixed(robot.extra_sources, robot.prefix),
    }
    return LoadedRobotView(
        namespace=robot.namespace,
        description=robot.description,
        placement=placement,
        control=MappingProxyType(dict(robot.modes)),
        actuated=robot.actuated,
        kinematic=tuple(n for n, m in robot.modes.items() if m == "kinematic"),
        joints=MappingProxyType(joints),
        actuators=MappingProxyType(actuators),
        bodies=MappingProxyType(bodies),
        home=MappingProxyType(home),
        sources=MappingProxyType({k: v for k, v in sources.items() if k in mine}),
        repairs=robot.repairs_made,
        notes=tuple(robot.notes),
        self_collision=robot.self_collision,
        base=robot.base,
    )


def home_positions(model: mujoco.MjModel, joints: Mapping[str, JointAddress]) -> dict[str, float]:
    """The ``home`` keyframe's position of each 1-dof joint of ``joints`` (the model's
    ``qpos0`` without a ``home`` key): a robot view's ``home``."""
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = model.key_qpos[key] if key >= 0 else model.qpos0
    return {
        joint: float(qpos[address.qpos]) for joint, address in joints.items() if address.nq == 1
    }


def _prefixed(sources: Mapping[str, bytes], prefix: str) -> dict[str, bytes]:
    """``"<role>/<rest>"`` -> ``"<role>/<prefix><rest>"`` (a robot's namespace in a world)."""
    out = {}
    for name, blob in sources.items():
        role, _, rest = name.partition("/")
        out[f"{role}/{prefix}{rest}"] = blob
    return out
