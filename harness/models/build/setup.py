"""What :func:`harness.models.load_world` does to each robot once its world compiled, to make
a real robot file behave (issue 14): start within the joint limits, gravity compensation by the
drives, the self-collision policy, placement on the floor, and one report of what was changed
and what touches at the start. Each step reads and writes a robot being built
(:class:`RobotInBuild`, the loader's own record) and the world's spec.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.build.drives import compensated_bodies
from harness.models.build.selfcollision import ignored_pairs, link_self_collide
from harness.models.description import ControlMode, Pose, RobotModel
from harness.models.errors import ModelStructureError, ModelWarning
from harness.models.world.placement import CLEARANCE, floor_gap, start_contacts
from harness.models.world.records import (
    BASE_KINDS,
    SELF_COLLISION_POLICIES,
    BaseKind,
    IgnoredPair,
    RobotSpec,
    SelfCollision,
    SelfCollisionReport,
)

__all__ = [
    "FLOATING_JOINT_SUFFIX",
    "RobotInBuild",
    "apply_self_collision",
    "check_options",
    "compensate_gravity",
    "make_floating",
    "place_on_floor",
    "report_start",
    "sdf_base",
    "self_collision_policy",
    "start_within_limits",
]


class RobotInBuild(Protocol):
    """What these steps read and write of the loader's record of a robot."""

    request: RobotSpec
    source: str
    kind: str
    prefix: str
    description: RobotModel
    modes: dict[str, ControlMode]
    extension_keys: Mapping[str, Mapping[str, float]]
    declared_self_collide: bool | None
    link_self_collide: dict[str, bool]
    srdf_pairs: tuple[tuple[str, str], ...]
    self_collision: SelfCollisionReport | None
    notes: list[str]
    base: BaseKind
    frame: Any
    repairs_made: tuple[str, ...]

    def joint_ids(self, model: mujoco.MjModel) -> list[int]: ...


def start_within_limits(model: mujoco.MjModel, robot: RobotInBuild) -> None:
    """A URDF/SDF robot starts at its zero configuration (or its ``home``); a joint whose
    zero lies outside its limits starts at the nearest limit instead (a real joint cannot be
    there), through the ``home`` keyframe, with a note."""
    if robot.kind == "mjcf":
        return
    home = dict(robot.extension_keys.get("home", {}))
    moved = []
    for joint in robot.description.joints:
        if joint.name in home or joint.mimic is not None or joint.type not in _SCALAR:
            continue
        lower, upper = joint.limits.lower, joint.limits.upper
        if joint.type == "continuous" or lower is None or upper is None or lower > upper:
            continue
        if not _has(model, mujoco.mjtObj.mjOBJ_JOINT, robot.prefix + joint.name):
            continue
        value = float(model.qpos0[model.jnt_qposadr[model.joint(robot.prefix + joint.name).id]])
        if lower <= value <= upper:
            continue
        home[joint.name] = min(max(value, lower), upper)
        moved.append(f"{joint.name} {value:g} -> {home[joint.name]:g}")
    for joint in robot.description.joints:  # mimic followers follow their leader
        mimic = joint.mimic
        if mimic is None or mimic.joint not in home or joint.name in home:
            continue
        if _has(model, mujoco.mjtObj.mjOBJ_JOINT, robot.prefix + joint.name):
            home[joint.name] = mimic.multiplier * home[mimic.joint] + mimic.offset
    if moved:
        robot.extension_keys = {**robot.extension_keys, "home": home}
        robot.notes.append(
            f"{robot.source}: zero configuration outside the joint limits; starts at the "
            f"nearest limit: {', '.join(moved)}"
        )


_SCALAR = ("revolute", "continuous", "prismatic")


def _has(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> bool:
    return bool(mujoco.mj_name2id(model, kind, name) >= 0)


def compensate_gravity(spec: mujoco.MjSpec, model: mujoco.MjModel, robot: RobotInBuild) -> None:
    """Gravity compensation by the drives, as real position-controlled robots have it (see
    :mod:`harness.models.build.drives`)."""
    modes = {int(model.joint(robot.prefix + joint).id): mode for joint, mode in robot.modes.items()}
    for joint in robot.description.joints:  # a mimic follower is driven by its leader's drive
        leader = robot.modes.get(joint.mimic.joint) if joint.mimic is not None else None
        if leader is not None and _has(model, mujoco.mjtObj.mjOBJ_JOINT, robot.prefix + joint.name):
            modes[int(model.joint(robot.prefix + joint.name).id)] = leader
    bodies = {
        link.name: int(model.body(robot.prefix + link.name).id)
        for link in robot.description.links
        if _has(model, mujoco.mjtObj.mjOBJ_BODY, robot.prefix + link.name)
    }
    for name in compensated_bodies(model, bodies, modes):
        spec.body(robot.prefix + name).gravcomp = 1.0
    for name, mode in robot.modes.items():
        if mode in ("position", "velocity"):
            spec.joint(robot.prefix + name).actgravcomp = True


def self_collision_policy(robot: RobotInBuild) -> tuple[SelfCollision, str]:
    request = robot.request
    if request.self_collision is not None:
        return request.self_collision, "argument"
    if robot.kind == "mjcf":
        return "on", "file"  # an MJCF robot's own contype/exclude settings stay as written
    if robot.declared_self_collide is not None:
        return ("on" if robot.declared_self_collide else "off"), "file"
    if request.srdf is not None:
        return "srdf", "srdf"
    return "auto", "default"


def apply_self_collision(
    spec: mujoco.MjSpec, model: mujoco.MjModel, robot: RobotInBuild, qpos: npt.NDArray[np.float64]
) -> None:
    """Exclude the link pairs the robot's self-collision policy ignores (see
    :mod:`harness.models.build.selfcollision`)."""
    policy, origin = self_collision_policy(robot)
    bodies = {
        link.name: int(model.body(robot.prefix + link.name).id)
        for link in robot.description.links
        if _has(model, mujoco.mjtObj.mjOBJ_BODY, robot.prefix + link.name)
    }
    bodies = {name: body for name, body in bodies.items() if body != 0}
    if robot.kind == "mjcf" and policy == "on":
        robot.self_collision = SelfCollisionReport(policy, origin)
        return
    pairs = list(ignored_pairs(model, bodies, robot.joint_ids(model), qpos, policy))
    if origin != "argument":  # the links' own self_collide (an argument overrides the file)
        pairs = link_self_collide(
            model, bodies, pairs, robot.link_self_collide, robot.declared_self_collide
        )
    known = {(p.link1, p.link2) for p in pairs} | {(p.link2, p.link1) for p in pairs}
    for link1, link2 in robot.srdf_pairs:
        if (link1, link2) not in known:
            pairs.append(IgnoredPair(link1, link2, "srdf"))
    for pair in pairs:
        if pair.reason != "srdf" and not _filtered_by_mujoco(
            model, bodies[pair.link1], bodies[pair.link2]
        ):
            spec.add_exclude(
                bodyname1=robot.prefix + pair.link1, bodyname2=robot.prefix + pair.link2
            )
    robot.self_collision = SelfCollisionReport(policy, origin, tuple(pairs))


def _filtered_by_mujoco(model: mujoco.MjModel, body1: int, body2: int) -> bool:
    """MuJoCo never collides a body with its parent (unless the parent is welded to the world)
    nor two bodies welded to the world: no exclude needed (the compiled model stays smaller)."""
    parent1, parent2 = int(model.body_parentid[body1]), int(model.body_parentid[body2])
    if parent1 == body2 and int(model.body_weldid[body2]) != 0:
        return True
    if parent2 == body1 and int(model.body_weldid[body1]) != 0:
        return True
    return int(model.body_weldid[body1]) == 0 and int(model.body_weldid[body2]) == 0


def place_on_floor(
    model: mujoco.MjModel,
    robot: RobotInBuild,
    qpos: npt.NDArray[np.float64],
    placement: Pose | None,
) -> Pose | None:
    """Lift a fixed robot out of the floor, set a floating one down on it (see
    :mod:`harness.models.world.placement`); returns the placement used."""
    bodies = [
        int(model.body(robot.prefix + link.name).id)
        for link in robot.description.links
        if _has(model, mujoco.mjtObj.mjOBJ_BODY, robot.prefix + link.name)
    ]
    if robot.base != "floating":  # links welded to the world never touch the floor
        bodies = [b for b in bodies if int(model.body_weldid[b]) != 0]
    gap = floor_gap(model, qpos, [b for b in bodies if b != 0])
    if gap is None:
        return placement
    if robot.base == "floating":
        lift = -gap
        if abs(lift) < 1e-9:
            return placement
        what = f"set down {gap:.4f} m onto the floor" if gap > 0 else f"lifted {lift:.4f} m"
        robot.notes.append(f"{robot.source}: floating base {what} (lowest point on the floor)")
    else:
        if gap >= 0.0:
            return placement
        lift = CLEARANCE - gap
        robot.notes.append(
            f"{robot.source}: links reach {-gap:.4f} m through the floor in the initial "
            f"configuration: robot lifted {lift:.4f} m"
        )
    pose = placement or Pose()
    moved = Pose((pose.xyz[0], pose.xyz[1], pose.xyz[2] + lift), pose.quat)
    robot.frame.pos = list(moved.xyz)
    own = set(bodies)
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE and int(model.jnt_bodyid[j]) in own:
            adr = int(model.jnt_qposadr[j]) + 2
            model.qpos0[adr] += lift
            qpos[adr] += lift
    return moved


def report_start(model: mujoco.MjModel, robots: Sequence[RobotInBuild]) -> None:
    """Warn once about every contact still present at the start, and about every note."""
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = np.array(model.key_qpos[key] if key >= 0 else model.qpos0)
    contacts = start_contacts(model, qpos)
    for robot in robots:
        for note in robot.notes:
            warnings.warn(note, ModelWarning, stacklevel=4)
        if robot.repairs_made:
            shown = "; ".join(robot.repairs_made[:6])
            more = len(robot.repairs_made) - 6
            warnings.warn(
                f"{robot.source}: repaired mass/inertia of {len(robot.repairs_made)} link(s) "
                f"(strict=True refuses instead): {shown}"
                + (f"; and {more} more (see .repairs)" if more > 0 else ""),
                ModelWarning,
                stacklevel=4,
            )
    if contacts:
        listed = ", ".join(str(c) for c in contacts[:8])
        extra = f" and {len(contacts) - 8} more" if len(contacts) > 8 else ""
        message = f"{len(contacts)} contact(s) at the start: {listed}{extra}"
        robots[0].notes.append(message)
        warnings.warn(message, ModelWarning, stacklevel=4)


def check_options(robot: RobotSpec, source: str) -> None:
    if robot.self_collision is not None and robot.self_collision not in SELF_COLLISION_POLICIES:
        raise ModelStructureError(
            f"{source}: unknown self_collision {robot.self_collision!r} (expected one of "
            f"{', '.join(SELF_COLLISION_POLICIES)})"
        )
    if robot.self_collision == "srdf" and robot.srdf is None:
        raise ModelStructureError(f"{source}: self_collision='srdf' but no srdf is given")
    if robot.base is not None and robot.base not in BASE_KINDS:
        raise ModelStructureError(
            f"{source}: unknown base {robot.base!r} (expected one of {', '.join(BASE_KINDS)})"
        )


FLOATING_JOINT_SUFFIX = "::__free__"
"""Suffix of the free joint a floating URDF robot's root link gets (as SDF's)."""


def make_floating(spec: mujoco.MjSpec, source: str) -> None:
    """Give each top body of a URDF robot a free joint (``base="floating"``)."""
    for body in spec.worldbody.bodies:
        if body.name == "world" or len(spec.worldbody.bodies) == 0:
            continue
        if any(True for _ in body.joints):
            raise ModelStructureError(
                f"{source}: base='floating' but the root link {body.name!r} is already jointed "
                "to the world"
            )
        body.add_freejoint(name=f"{body.name}{FLOATING_JOINT_SUFFIX}")


def sdf_base(spec: mujoco.MjSpec, base: BaseKind | None) -> BaseKind:
    """Apply ``base`` to a built SDF spec: free root links (non-static models) are floating;
    ``"fixed"`` removes their free joints."""
    free = [
        joint
        for body in spec.worldbody.bodies
        for joint in body.joints
        if joint.type == mujoco.mjtJoint.mjJNT_FREE
    ]
    if base == "fixed":
        for joint in free:
            spec.delete(joint)
        return "fixed"
    if base == "floating" and not free:
        raise ModelStructureError(
            "base='floating' for a static SDF model (remove <static>, or load it fixed)"
        )
    return "floating" if free else "fixed"
