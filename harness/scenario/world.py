"""The world of one iteration: a scenario's map, objects, robots (poses, control modes, initial
joint positions, namespaces) turned into the :func:`harness.models.load_world` call a Session
runs.

What goes where, so that replay can rebuild it:

- ``environment.map``, ``objects`` and ``timestep`` become the *scene*: the built-in scene or
  the MJCF world file as is when there is nothing to add, else a generated MJCF world
  (``scene.xml`` in the iteration's folder) holding the map's content plus the objects. The
  scene file travels in the recording as a source attachment.
- each ``robots[]`` entry becomes a :class:`harness.models.RobotSpec`: ``controllers`` its
  control modes, ``position``/``orientation`` its pose (x y z, then fixed-axis roll pitch
  yaw), ``initial_joint_positions`` its ``initial_positions`` (the ``home`` keyframe the
  Simulation starts from). The recording's ``robots`` metadata holds all of it, so
  ``resimulate`` and ``--level full`` rebuild the same world.

Namespaces (:func:`robot_namespaces`): a scenario with one robot runs it in the empty
namespace (global topics ``/joint_states``, ``/joint_command``, ...), as before. With several
robots each robot's topics live under ``/<namespace>/``: a robot's ``name`` given in the file
is its namespace; a robot without one (the original format has no ``name``) takes its model's
name (``demo_arm``), made unique with ``_1``, ``_2``, ... (``demo_arm``, ``demo_arm_1``). Its
subscribers' topics are put under the namespace (``/joint_command`` becomes
``/<namespace>/joint_command``; a topic already under ``/<namespace>/`` stays).

:func:`check_runnable` lists what the session-backed runner cannot run, each problem naming
the scenario file and the key path.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import mujoco

from harness.errors import ModelError
from harness.models import (
    SCENES,
    ControlMode,
    LoadedRobot,
    LoadedWorld,
    RobotModel,
    add_object,
    check_mesh_collision,
    check_mjcf_files,
    generated_from,
    is_sdf_world,
    load_description,
    load_world,
    load_world_file,
    world_timestep,
)
from harness.models import RobotSpec as WorldRobot
from harness.scenario._validation import format_path
from harness.scenario.errors import ScenarioError
from harness.scenario.scenario import Scenario, ScenarioRobot
from harness.vocabulary import LimitPolicy

__all__ = [
    "DEFAULT_JOINT_COMMAND_TOPIC",
    "TRAJECTORY_TOPIC",
    "WorldPlan",
    "build_world",
    "check_runnable",
    "control_modes",
    "effective_timestep",
    "initial_positions",
    "joint_command_topic",
    "kinematic_limits",
    "plan_world",
    "require_runnable",
    "robot_namespaces",
    "robot_pose",
    "scene_for",
]

DEFAULT_JOINT_COMMAND_TOPIC = "/joint_command"
"""The Session's joint command topic when a robot lists no JointStateSubscriber."""
TRAJECTORY_TOPIC = "/joint_trajectory"
"""The trajectory topic the Session serves for a robot (under its namespace, if any)."""
_HINGE_LIKE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def _where(scenario: Scenario) -> str:
    return str(scenario.source) if scenario.source is not None else "<scenario>"


def check_runnable(scenario: Scenario) -> list[str]:
    """What the session-backed runner cannot run in ``scenario`` (empty: runnable). Each
    entry is ``"<file>: <key path>: <value> <problem>"``."""
    where = _where(scenario)
    problems: list[str] = []

    def problem(path: list[str | int], value: object, text: str) -> None:
        problems.append(f"{where}: {format_path(path)}: {value!r} {text}")

    several = len(scenario.robots) > 1
    for index, robot in enumerate(scenario.robots):
        state_topics = [
            (i, s) for i, s in enumerate(robot.subscribers) if s.type == "JointStateSubscriber"
        ]
        for i, sub in state_topics[1:]:
            problem(
                ["robots", index, "subscribers", i],
                sub.topic,
                f"is a second JointStateSubscriber: a robot takes joint commands on one topic "
                f"(here {state_topics[0][1].topic!r})",
            )
        for i, sub in enumerate(robot.subscribers):
            if sub.type != "JointTrajectorySubscriber":
                continue
            served = TRAJECTORY_TOPIC
            if several and sub.topic != TRAJECTORY_TOPIC:
                served = f"/{robot_namespaces(scenario)[index]}{TRAJECTORY_TOPIC}"
            if sub.topic not in (TRAJECTORY_TOPIC, served):
                problem(
                    ["robots", index, "subscribers", i, "topic"],
                    sub.topic,
                    f"is not served: trajectories are taken on {served!r} only",
                )
        limits = {c.kinematic_limits for c in robot.modes if c.mode == "kinematic"}
        if len(limits) > 1:
            problem(
                ["robots", index, "modes"],
                sorted(limits),
                "mix kinematic_limits values: kinematic joints of one robot share one policy",
            )
    policies = [kinematic_limits(robot) for robot in scenario.robots]
    for index, policy in enumerate(policies[1:], start=1):
        if policy != policies[0]:
            problem(
                ["robots", index, "modes"],
                policy,
                f"differs from robots[0]'s kinematic_limits ({policies[0]!r}): the kinematic "
                "joints of one run share one policy",
            )
            break
    return problems


def require_runnable(scenario: Scenario) -> None:
    """Raise :class:`ScenarioError` listing what :func:`check_runnable` found."""
    problems = check_runnable(scenario)
    if problems:
        raise ScenarioError(problems)


def control_modes(
    robot: ScenarioRobot, description: RobotModel, path: list[str | int], where: str = "<scenario>"
) -> dict[str, ControlMode]:
    """Every controllable joint's mode from ``robots[].modes`` (``path``: the robot's
    key path): a controller without ``joints`` covers every joint; later controllers win;
    joints no controller names are left out, so that they get the loader's default (position,
    or what the robot file's drive plugin or ``<ros2_control>`` interfaces drive them with, as
    for ``Session`` and ``harness serve``)."""
    controllable = [j.name for j in description.controllable_joints]
    modes: dict[str, ControlMode] = {}
    problems = []
    for i, controller in enumerate(robot.modes):
        for joint in controller.joints or controllable:
            if joint not in controllable:
                problems.append(
                    f"{where}: {format_path([*path, 'modes', i, 'joints'])}: {joint!r} "
                    f"is not a controllable joint of the robot (controllable: "
                    f"{', '.join(controllable)})"
                )
                continue
            modes[joint] = controller.mode
    if problems:
        raise ScenarioError(problems)
    return modes


def kinematic_limits(robot: ScenarioRobot) -> LimitPolicy:
    """``allow`` when a kinematic controller lets commands pass the limits, else ``clamp``."""
    allow = any(
        c.mode == "kinematic" and c.kinematic_limits == LimitPolicy.ALLOW for c in robot.modes
    )
    return LimitPolicy.ALLOW if allow else LimitPolicy.CLAMP


def joint_command_topic(robot: ScenarioRobot, namespace: str = "") -> str:
    """The JointStateSubscriber's topic (the original's default ``/joint/states``), else
    :data:`DEFAULT_JOINT_COMMAND_TOPIC`; with a ``namespace``, relative to it (a topic
    already under ``/<namespace>/`` stays absolute)."""
    topic = DEFAULT_JOINT_COMMAND_TOPIC
    for sub in robot.subscribers:
        if sub.type == "JointStateSubscriber":
            topic = sub.topic
            break
    if not namespace or topic.startswith(f"/{namespace}/"):
        return topic
    return topic.lstrip("/")


def _segment(name: str) -> str:
    """``name`` as a ROS name segment (a letter first, letters, digits, single ``_``)."""
    text = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_")
    return text if text[:1].isalpha() else f"robot_{text}".rstrip("_")


def robot_namespaces(scenario: Scenario) -> tuple[str, ...]:
    """Each robot's namespace (see the module docstring): ``("",)`` for a lone robot; with
    several, a given ``name``, else the model's name made unique (``demo_arm``,
    ``demo_arm_1``, ...)."""
    robots = scenario.robots
    if len(robots) <= 1:
        return ("",) * len(robots)
    used = {r.name for r in robots if r.named}
    out: list[str] = []
    for robot in robots:
        if robot.named:
            out.append(robot.name)
            continue
        base = _segment(load_description(robot.robot, robot_args=robot.robot_args).name)
        candidate, number = base, 0
        while candidate in used:
            number += 1
            candidate = f"{base}_{number}"
        used.add(candidate)
        out.append(candidate)
    return tuple(out)


def scene_for(scenario: Scenario, folder: Path) -> str | Path:
    """The loader's ``scene``: the map itself, or a generated MJCF world in ``folder`` when
    objects or a timestep other than the map's must be added."""
    env_map = scenario.environment.map
    file = env_map if isinstance(env_map, Path) else SCENES[env_map]
    try:
        if is_sdf_world(file):
            spec = _sdf_world_spec(scenario, file)
        else:
            check_mjcf_files(file)
            spec = mujoco.MjSpec.from_file(str(file))
    except (ValueError, ModelError) as exc:
        raise ScenarioError(
            [f"{_where(scenario)}: environment.map: {str(file)!r} {' '.join(str(exc).split())}"]
        ) from None
    base = file.parent
    same_step = scenario.timestep is None or spec.option.timestep == scenario.timestep
    if not scenario.objects and same_step:
        return env_map
    if scenario.timestep is not None:
        spec.option.timestep = scenario.timestep
    existing = {b.name for b in spec.bodies if b.name}
    for index, obj in enumerate(scenario.objects):
        if obj.name in existing:
            raise ScenarioError(
                [
                    f"{_where(scenario)}: objects[{index}].name: {obj.name!r} is already a body "
                    f"of the map {_map_name(env_map)!r}; choose another name"
                ]
            )
        try:
            add_object(spec, obj, f"{_where(scenario)}: objects[{index}] ({obj.name!r})")
        except ModelError as exc:  # a Scenario built in Python, not read from a file
            raise ScenarioError([str(exc)]) from None
    # Keep asset paths valid from the generated file's folder.
    spec.meshdir = str((base / spec.meshdir).resolve()) if spec.meshdir else str(base)
    spec.texturedir = str((base / spec.texturedir).resolve()) if spec.texturedir else str(base)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.xml"
    path.write_text(spec.to_xml())
    generated_from(path, file)  # its meshdir/texturedir point back at the map's folder
    return path


def _sdf_world_spec(scenario: Scenario, file: Path) -> mujoco.MjSpec:
    """The SDF world ``file`` as a spec that can be written out with the scenario's objects
    (refused when the world brings meshes: they live in memory, not beside the file)."""
    world = load_world_file(file)
    own = world.spec.option.timestep
    if world.spec.assets and scenario.timestep is not None and scenario.timestep != own:
        raise ScenarioError(
            [
                f"{_where(scenario)}: timestep: {scenario.timestep!r} is not the world's "
                f"<max_step_size> {own!r} ({str(file)!r} has meshes, so it keeps its own "
                "step; leave timestep out to run at the world's)"
            ]
        )
    if world.spec.assets and scenario.objects:
        raise ScenarioError(
            [
                f"{_where(scenario)}: environment.map: {str(file)!r} has meshes: objects "
                "cannot be added to it; put them in the world file"
            ]
        )
    return world.spec


def effective_timestep(scenario: Scenario) -> float:
    """The physics step a scenario runs at: its ``timestep``, else its map's own (an SDF
    world's ``<max_step_size>``, an MJCF scene's ``<option timestep>``; MuJoCo's 0.002 when
    the map sets none)."""
    if scenario.timestep is not None:
        return scenario.timestep
    env_map = scenario.environment.map
    file = env_map if isinstance(env_map, Path) else SCENES[env_map]
    try:
        if is_sdf_world(file):
            return world_timestep(file)
        check_mjcf_files(file)
        return float(mujoco.MjSpec.from_file(str(file)).option.timestep)
    except (ValueError, ModelError) as exc:
        raise ScenarioError(
            [f"{_where(scenario)}: environment.map: {str(file)!r} {' '.join(str(exc).split())}"]
        ) from None


def _map_name(env_map: str | Path) -> str:
    return env_map.name if isinstance(env_map, Path) else env_map


class WorldPlan(NamedTuple):
    """What :func:`harness.models.load_world` (or ``Session(robots=..., scene=...)``) gets
    for a scenario: one :class:`harness.models.RobotSpec` per robot, the scene, and per
    robot namespace its joint command topic."""

    robots: tuple[WorldRobot, ...]
    scene: str | Path
    command_topics: Mapping[str, str]


def _joint_names(description: RobotModel) -> list[str]:
    return [j.name for j in description.joints if j.type in ("revolute", "continuous", "prismatic")]


def _object_clashes(
    scenario: Scenario, description: RobotModel, namespace: str, index: int, where: str
) -> list[str]:
    """Objects named like a robot's link or joint (MuJoCo would refuse the world naming the
    robot's file instead of the scenario's)."""
    prefix = f"{namespace}/" if namespace else ""
    taken = {prefix + link.name for link in description.links}
    taken |= {prefix + joint.name for joint in description.joints}
    return [
        f"{where}: objects[{number}].name: {obj.name!r} is already a link or joint name of "
        f"robots[{index}] ({scenario.robots[index].robot}); choose another name"
        for number, obj in enumerate(scenario.objects)
        if obj.name in taken or f"{obj.name}_joint" in taken
    ]


def plan_world(scenario: Scenario, folder: Path) -> WorldPlan:
    """The world of ``scenario`` (see the module docstring); a generated scene goes to
    ``folder``. Errors name the scenario file and the key path."""
    require_runnable(scenario)
    where = _where(scenario)
    namespaces = robot_namespaces(scenario)
    robots: list[WorldRobot] = []
    problems: list[str] = []
    for index, (robot, namespace) in enumerate(zip(scenario.robots, namespaces, strict=True)):
        description = load_description(robot.robot, robot_args=robot.robot_args)
        modes = control_modes(robot, description, ["robots", index], where)
        joints = _joint_names(description)
        problems += [
            f"{where}: robots[{index}].initial_joint_positions.{name}: {value!r} names no "
            f"hinge or slide joint of the robot (joints: {', '.join(sorted(joints))})"
            for name, value in robot.initial_joint_positions.items()
            if name not in joints
        ]
        problems += _object_clashes(scenario, description, namespace, index, where)
        robots.append(
            WorldRobot(
                robot.robot,
                namespace=namespace,
                pose=robot_pose(robot),
                control=modes,
                initial_positions=dict(robot.initial_joint_positions),
                robot_args=dict(robot.robot_args),
                self_collision=robot.self_collision,
                srdf=robot.srdf,
                base=robot.base,
                strict=robot.strict,
            )
        )
    if problems:
        raise ScenarioError(problems)
    topics = {
        namespace: joint_command_topic(robot, namespace)
        for robot, namespace in zip(scenario.robots, namespaces, strict=True)
    }
    return WorldPlan(tuple(robots), scene_for(scenario, folder), topics)


def robot_pose(robot: ScenarioRobot) -> list[float] | None:
    """A robot's ``pose`` as its :class:`harness.models.RobotSpec` gets it: x y z, then roll
    pitch yaw; None (no placement) when the file leaves the robot at the origin."""
    posed = robot.position != (0.0, 0.0, 0.0) or robot.orientation != (0.0, 0.0, 0.0)
    return [*robot.position, *robot.orientation] if posed else None


def build_world(scenario: Scenario, folder: Path) -> LoadedWorld:
    """Load the world of ``scenario`` (:func:`plan_world`, then
    :func:`harness.models.load_world`); a model error names the scenario file."""
    plan = plan_world(scenario, folder)
    try:
        return load_world(
            plan.robots,
            scene=plan.scene,
            mesh_collision=check_mesh_collision(
                scenario.environment.mesh_collision, "environment.mesh_collision"
            ),
        )
    except ModelError as exc:
        raise ScenarioError([f"{_where(scenario)}: {exc}"]) from None


def initial_positions(loaded: LoadedRobot | LoadedWorld) -> Mapping[str, float]:
    """The ``home`` keyframe's hinge/slide joint positions (for reports and tests)."""
    model = loaded.model
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = model.key_qpos[key] if key >= 0 else model.qpos0
    return {
        model.joint(j).name: float(qpos[model.jnt_qposadr[j]])
        for j in range(model.njnt)
        if int(model.jnt_type[j]) in _HINGE_LIKE
    }
