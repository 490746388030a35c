"""The world of one iteration: a scenario's map, objects, robot pose, control modes and
initial joint positions turned into the :class:`~harness.models.LoadedRobot` a Session runs.

What goes where, so that replay can rebuild it:

- ``environment.map``, ``objects`` and ``timestep`` become the *scene*: the built-in scene or
  the MJCF world file as is when there is nothing to add, else a generated MJCF world
  (``scene.xml`` in the iteration's folder) holding the map's content plus the objects. The
  scene file travels in the recording as a source attachment, so ``resimulate`` (which
  rebuilds the robot from its sources) sees the objects too.
- ``robots[].controllers`` become the control modes passed to the loader.
- ``robots[].position``/``orientation`` and ``initial_joint_positions`` are applied to the
  compiled spec afterwards (the robot's attachment frame is moved; the ``home`` keyframe,
  which the Simulation starts from, is rewritten). The exact binary model (``model.mjb``)
  carries them, so ``verify`` replays them bit for bit; ``resimulate`` starts from the
  recorded initial state (so initial joint positions hold there too) but rebuilds the robot
  at the origin.

:func:`check_runnable` lists what the session-backed runner cannot run, each problem naming
the scenario file and the key path.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import mujoco
import numpy as np

from harness.models import SCENES, ControlMode, LoadedRobot, load_description, load_robot
from harness.models.description import RobotModel
from harness.scenario._validation import format_path
from harness.scenario.errors import ScenarioError
from harness.scenario.scenario import RobotSpec, Scenario, SceneObject
from harness.sim import KinematicLimits

__all__ = [
    "DEFAULT_JOINT_COMMAND_TOPIC",
    "TRAJECTORY_TOPIC",
    "build_robot",
    "check_runnable",
    "control_modes",
    "initial_positions",
    "joint_command_topic",
    "kinematic_limits",
    "require_runnable",
    "scene_for",
]

DEFAULT_JOINT_COMMAND_TOPIC = "/joint_command"
"""The Session's joint command topic when a robot lists no JointStateSubscriber."""
TRAJECTORY_TOPIC = "/joint_trajectory"
"""The only trajectory topic the Session serves (for a robot without a namespace)."""
_HINGE_LIKE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
_SHAPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
}


def _where(scenario: Scenario) -> str:
    return str(scenario.source) if scenario.source is not None else "<scenario>"


def check_runnable(scenario: Scenario) -> list[str]:
    """What the session-backed runner cannot run in ``scenario`` (empty: runnable). Each
    entry is ``"<file>: <key path>: <value> <problem>"``."""
    where = _where(scenario)
    problems: list[str] = []

    def problem(path: list[str | int], value: object, text: str) -> None:
        problems.append(f"{where}: {format_path(path)}: {value!r} {text}")

    if len(scenario.robots) > 1:
        problem(
            ["robots", 1],
            scenario.robots[1].name,
            f"is a second robot: a run simulates one robot per scenario (this one lists "
            f"{len(scenario.robots)}); split it into one scenario per robot",
        )
    env_map = scenario.environment.map
    if isinstance(env_map, Path) and env_map.suffix.lower() in (".sdf", ".world"):
        problem(
            ["environment", "map"],
            str(env_map),
            "is an SDF world: a run's map must be a built-in scene or an MJCF world file",
        )
    for index, robot in enumerate(scenario.robots[:1]):
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
            if sub.type == "JointTrajectorySubscriber" and sub.topic != TRAJECTORY_TOPIC:
                problem(
                    ["robots", index, "subscribers", i, "topic"],
                    sub.topic,
                    f"is not served: trajectories are taken on {TRAJECTORY_TOPIC!r} only",
                )
        limits = {c.beyond_limits for c in robot.controllers if c.mode == "kinematic"}
        if len(limits) > 1:
            problem(
                ["robots", index, "controllers"],
                sorted(limits),
                "mix beyond_limits values: kinematic joints of one robot share one policy",
            )
    return problems


def require_runnable(scenario: Scenario) -> None:
    """Raise :class:`ScenarioError` listing what :func:`check_runnable` found."""
    problems = check_runnable(scenario)
    if problems:
        raise ScenarioError(problems)


def control_modes(
    robot: RobotSpec, description: RobotModel, path: list[str | int], where: str = "<scenario>"
) -> dict[str, ControlMode]:
    """Every controllable joint's mode from ``robots[].controllers`` (``path``: the robot's
    key path): a controller without ``joints`` covers every joint; later controllers win;
    joints no controller names are ``position``."""
    controllable = [j.name for j in description.controllable_joints]
    modes: dict[str, ControlMode] = dict.fromkeys(controllable, "position")
    problems = []
    for i, controller in enumerate(robot.controllers):
        for joint in controller.joints or controllable:
            if joint not in modes:
                problems.append(
                    f"{where}: {format_path([*path, 'controllers', i, 'joints'])}: {joint!r} "
                    f"is not a controllable joint of the robot (controllable: "
                    f"{', '.join(controllable)})"
                )
                continue
            modes[joint] = controller.mode
    if problems:
        raise ScenarioError(problems)
    return modes


def kinematic_limits(robot: RobotSpec) -> KinematicLimits:
    """``"allow"`` when a kinematic controller lets commands pass the limits, else ``"clamp"``."""
    allow = any(c.mode == "kinematic" and c.beyond_limits == "allow" for c in robot.controllers)
    return "allow" if allow else "clamp"


def joint_command_topic(robot: RobotSpec) -> str:
    """The JointStateSubscriber's topic (the original's default ``/joint/states``), else
    :data:`DEFAULT_JOINT_COMMAND_TOPIC`."""
    for sub in robot.subscribers:
        if sub.type == "JointStateSubscriber":
            return sub.topic
    return DEFAULT_JOINT_COMMAND_TOPIC


def scene_for(scenario: Scenario, folder: Path) -> str | Path:
    """The loader's ``scene``: the map itself, or a generated MJCF world in ``folder`` when
    objects or a timestep other than the map's must be added."""
    env_map = scenario.environment.map
    file = env_map if isinstance(env_map, Path) else SCENES[env_map]
    try:
        spec = mujoco.MjSpec.from_file(str(file))
    except ValueError as exc:
        raise ScenarioError(
            [f"{_where(scenario)}: environment.map: {str(file)!r} {' '.join(str(exc).split())}"]
        ) from None
    base = file.parent
    same_step = spec.option.timestep == scenario.timestep
    if not scenario.objects and same_step:
        return env_map
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
        _add_object(spec, obj)
    # Keep asset paths valid from the generated file's folder.
    spec.meshdir = str((base / spec.meshdir).resolve()) if spec.meshdir else str(base)
    spec.texturedir = str((base / spec.texturedir).resolve()) if spec.texturedir else str(base)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.xml"
    path.write_text(spec.to_xml())
    return path


def _map_name(env_map: str | Path) -> str:
    return env_map.name if isinstance(env_map, Path) else env_map


def _quat(rpy: tuple[float, float, float]) -> list[float]:
    """w-x-y-z quaternion of fixed-axis roll, pitch, yaw (URDF convention)."""
    r, p, y = (a / 2 for a in rpy)
    cr, sr = math.cos(r), math.sin(r)
    cp, sp = math.cos(p), math.sin(p)
    cy, sy = math.cos(y), math.sin(y)
    return [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]


def _add_object(spec: mujoco.MjSpec, obj: SceneObject) -> None:
    body = spec.worldbody.add_body(
        name=obj.name, pos=list(obj.position), quat=_quat(obj.orientation)
    )
    geom_options: dict[str, object] = {"name": obj.name, "type": _SHAPES[obj.shape]}
    size = list(obj.size) + [0.0] * (3 - len(obj.size))
    geom_options["size"] = size
    if obj.rgba is not None:
        geom_options["rgba"] = list(obj.rgba)
    if obj.mass is not None:
        body.add_freejoint(name=f"{obj.name}_joint")
        geom_options["mass"] = obj.mass
    body.add_geom(**geom_options)


def build_robot(scenario: Scenario, folder: Path) -> LoadedRobot:
    """Load the scenario's (single) robot into its world (see the module docstring)."""
    require_runnable(scenario)
    robot = scenario.robots[0]
    modes = control_modes(robot, load_description(robot.robot), ["robots", 0], _where(scenario))
    loaded = load_robot(robot.robot, control=modes, scene=scene_for(scenario, folder))
    posed = robot.position != (0.0, 0.0, 0.0) or robot.orientation != (0.0, 0.0, 0.0)
    if not posed and not robot.initial_joint_positions:
        return loaded
    return _edit(loaded, robot, scenario)


def _edit(loaded: LoadedRobot, robot: RobotSpec, scenario: Scenario) -> LoadedRobot:
    spec = loaded.spec
    before = loaded.model
    home = {k.name: k for k in spec.keys}.get("home")
    index = 0
    positions: dict[str, float] = {}
    key_qpos = before.key_qpos[0] if home is not None else before.qpos0
    for j in range(before.njnt):
        if int(before.jnt_type[j]) in _HINGE_LIKE:
            positions[before.joint(j).name] = float(key_qpos[before.jnt_qposadr[j]])
    wanted = dict(robot.initial_joint_positions)
    unknown = sorted(set(wanted) - set(positions))
    if unknown:
        raise ScenarioError(
            [
                f"{_where(scenario)}: robots[{index}].initial_joint_positions.{name}: "
                f"{wanted[name]!r} names no hinge or slide joint of the robot (joints: "
                f"{', '.join(sorted(positions))})"
                for name in unknown
            ]
        )
    positions.update(wanted)

    links = {link.name for link in loaded.description.links}
    top = [b for b in spec.worldbody.bodies if b.name in links]
    quat = _quat(robot.orientation)
    for body in top:
        frame = body.frame
        if frame is not None:
            frame.pos = list(robot.position)
            frame.quat = quat
        else:
            pos = np.zeros(3)
            mujoco.mju_rotVecQuat(pos, np.asarray(body.pos, dtype=float), np.asarray(quat))
            composed = np.zeros(4)
            mujoco.mju_mulQuat(composed, np.asarray(quat), np.asarray(body.quat, dtype=float))
            body.pos = (pos + np.asarray(robot.position)).tolist()
            body.quat = composed.tolist()
    with warnings.catch_warnings():
        # The loader attached the robot with an empty prefix on purpose (names unchanged).
        warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")
        for key in list(spec.keys):
            spec.delete(key)
        layout = _compile(spec, scenario, index)
        qpos = np.array(layout.qpos0, dtype=float)
        for name, value in positions.items():
            qpos[layout.jnt_qposadr[layout.joint(name).id]] = value
        ctrl = [
            positions.get(joint, 0.0) if loaded.control.get(joint) == "position" else 0.0
            for joint in loaded.actuated
        ]
        spec.add_key(name="home", qpos=qpos.tolist(), ctrl=ctrl)
        model = _compile(spec, scenario, index)
        mjcf = spec.to_xml()
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return dataclasses.replace(
        loaded,
        model=model,
        mjcf=mjcf,
        mjb=buffer.tobytes(),
        sha256=hashlib.sha256(mjcf.encode()).hexdigest(),
    )


def _compile(spec: mujoco.MjSpec, scenario: Scenario, index: int) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        raise ScenarioError(
            [
                f"{_where(scenario)}: robots[{index}]: the posed robot does not compile: "
                f"{' '.join(str(exc).split())}"
            ]
        ) from None


def initial_positions(loaded: LoadedRobot) -> Mapping[str, float]:
    """The ``home`` keyframe's hinge/slide joint positions (for reports and tests)."""
    model = loaded.model
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    qpos = model.key_qpos[key] if key >= 0 else model.qpos0
    return {
        model.joint(j).name: float(qpos[model.jnt_qposadr[j]])
        for j in range(model.njnt)
        if int(model.jnt_type[j]) in _HINGE_LIKE
    }
