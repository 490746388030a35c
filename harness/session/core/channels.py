"""The session's robots as their topics see them: each robot's resolved topic names
(:class:`SessionTopics`), joints, links and ``joint_states`` layout (:class:`RobotChannels`),
built for one robot or every robot of a world by :func:`robot_channels`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.controllers.command_topics import FORWARD_TOPICS, Reporter, RobotCommands
from harness.controllers.listed import ListedJoints
from harness.models import LoadedRobot, LoadedWorld, RobotModel
from harness.recording import JointStateRecord
from harness.session.core.tf import RobotFrames
from harness.session.core.topics import joint_state_msg
from harness.session.core.urdf_text import description_text
from harness.session.errors import SessionConfigError
from harness.sim import CommandField, RobotJoints, Simulation

__all__ = [
    "RobotChannels",
    "SessionTopics",
    "joint_state_arrays",
    "joint_state_message",
    "joint_state_of",
    "joint_state_record",
    "robot_channels",
    "robot_frames",
]

F64 = npt.NDArray[np.float64]

TF = "/tf"
TF_STATIC = "/tf_static"
CLOCK = "/clock"
ROSOUT = "/rosout"


@dataclass(frozen=True)
class SessionTopics:
    """The resolved names of the robot's topics."""

    joint_states: str
    joint_command: str
    joint_trajectory: str
    tf: str
    robot_description: str
    forward: Mapping[CommandField, str] = field(default_factory=dict)
    tf_static: str = TF_STATIC
    clock: str = CLOCK
    rosout: str = ROSOUT


class RobotChannels:
    """One robot of a session, as its topics see it: ``namespace`` (ROS), ``prefix`` (of its
    MuJoCo names), its own ``description`` (unprefixed names), its controllable ``joints``
    (:class:`~harness.sim.RobotJoints`), resolved ``topics``, ``links`` (MuJoCo body names of
    its links: the ``/tf`` child frames are ``<namespace>/<link>``), the latched
    ``robot_description`` text and its command topics (``commands``, with the trajectory in
    progress)."""

    def __init__(
        self,
        sim: Simulation,
        namespace: str,
        prefix: str,
        description: RobotModel,
        control: Iterable[str],
        topics: SessionTopics,
        description_text: str,
        report: Reporter,
    ) -> None:
        self.namespace = namespace
        self.prefix = prefix
        self.description = description
        self.joints = RobotJoints(sim, control, prefix)
        self.topics = topics
        self.description_text = description_text
        model = sim.model
        self.links = tuple(
            prefix + link.name
            for link in description.links
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + link.name) >= 0
        )
        frame_prefix = f"{namespace}/" if namespace else ""
        self.frames = tuple(frame_prefix + link.removeprefix(prefix) for link in self.links)
        kinematic = set(sim.kinematic_joints)
        names: list[str] = []
        qadr: list[int] = []
        dadr: list[int] = []
        kin: list[bool] = []
        slide_hinge = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        for joint in description.joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, prefix + joint.name)
            if jid < 0 or int(model.jnt_type[jid]) not in slide_hinge:
                continue
            names.append(joint.name)
            qadr.append(int(model.jnt_qposadr[jid]))
            dadr.append(int(model.jnt_dofadr[jid]))
            kin.append(prefix + joint.name in kinematic)
        self.js_names = tuple(names)
        """The joints in its ``joint_states`` (every hinge and slide joint, unprefixed)."""
        self.js_qadr = np.array(qadr, dtype=np.intp)
        self.js_dadr = np.array(dadr, dtype=np.intp)
        self.js_kin = np.array(kin, dtype=bool)
        # how joint_state_arrays reads them: a slice (a view, no gather) when consecutive,
        # and the efforts of one source when every joint is kinematic or none is
        self.js_qpos_index = _consecutive(self.js_qadr)
        self.js_dof_index = _consecutive(self.js_dadr)
        self.js_effort_source = (
            "qfrc_applied"
            if self.js_kin.all()
            else "qfrc_actuator"
            if not self.js_kin.any()
            else ""
        )
        """The layout of the robot's ``joint_states`` in the recording."""
        self.listed = ListedJoints(description, self.js_names, self.joints.joint_names)
        """Listed on ``joint_states`` but not controllable: dropped from ``joint_command``."""
        self.commands = RobotCommands(
            self.joints,
            self.listed,
            lambda: sim.data.qpos[self.js_qadr],
            report,
            joint_command=topics.joint_command,
            joint_trajectory=topics.joint_trajectory,
        )
        """The robot's command topics (and its trajectory in progress)."""

    def drop_from_trajectory(self, joints: Iterable[str]) -> None:
        """Stop the trajectory driving ``joints`` (the robot's own names)."""
        self.commands.drop_from_trajectory(joints)


def robot_frames(channels: RobotChannels) -> RobotFrames:
    """The robot's ``/tf`` frames (frame ids ``<namespace>/<link>``)."""
    prefix = f"{channels.namespace}/" if channels.namespace else ""
    return RobotFrames(channels.description, channels.prefix, prefix)


def joint_state_arrays(sim: Simulation, channels: RobotChannels) -> tuple[F64, F64, F64]:
    """The robot's joint positions, velocities and efforts now, in ``joint_states`` order
    (effort: the applied force of a kinematic joint, the actuator force of the others); views
    of the simulation's arrays where they can be: read them before the next step."""
    data = sim.data
    dof = channels.js_dof_index
    if channels.js_effort_source:
        effort: F64 = getattr(data, channels.js_effort_source)[dof]
    else:
        effort = np.where(channels.js_kin, data.qfrc_applied[dof], data.qfrc_actuator[dof])
    return data.qpos[channels.js_qpos_index], data.qvel[dof], effort


def _consecutive(addresses: npt.NDArray[np.intp]) -> slice | npt.NDArray[np.intp]:
    """``addresses`` as a slice when they are consecutive (indexing gives a view)."""
    if addresses.size and np.array_equal(
        addresses, np.arange(addresses[0], addresses[0] + addresses.size)
    ):
        return slice(int(addresses[0]), int(addresses[0]) + addresses.size)
    return addresses


def joint_state_message(
    sim_time_ns: int, channels: RobotChannels, arrays: Callable[[], tuple[F64, F64, F64]]
) -> dict[str, Any]:
    """:func:`joint_state_of` (no prefix) from ``arrays()`` (:func:`joint_state_arrays`)."""
    return joint_state_msg(sim_time_ns, channels.js_names, *arrays())


def joint_state_record(
    sim_time_ns: int, channels: RobotChannels, arrays: Callable[[], tuple[F64, F64, F64]]
) -> JointStateRecord:
    """:func:`joint_state_message` as the recording's record of it."""
    return JointStateRecord(sim_time_ns, channels.js_names, *arrays())


def joint_state_of(sim: Simulation, channels: RobotChannels, prefix: str = "") -> dict[str, Any]:
    """The robot's ``sensor_msgs/msg/JointState`` now (joint names with ``prefix``)."""
    names = channels.js_names if not prefix else [prefix + n for n in channels.js_names]
    return joint_state_msg(sim.sim_time_ns, names, *joint_state_arrays(sim, channels))


def _resolve(name: str, namespace: str, check_name: Callable[[str, str], str]) -> str:
    check_name(name, "topic")
    if name.startswith("/"):
        return name
    return f"/{namespace}/{name}" if namespace else f"/{name}"


def _topics(
    namespace: str,
    tf: str | None,
    command_topic: str,
    check_name: Callable[[str, str], str],
) -> SessionTopics:
    def resolve(name: str) -> str:
        return _resolve(name, namespace, check_name)

    return SessionTopics(
        joint_states=resolve("joint_states"),
        joint_command=resolve(command_topic),
        joint_trajectory=resolve("joint_trajectory"),
        tf=resolve("tf") if tf is None else tf,
        robot_description=resolve("robot_description"),
        forward=MappingProxyType({f: resolve(t) for f, t in FORWARD_TOPICS.items()}),
        tf_static=resolve("tf_static") if tf is None else TF_STATIC,
    )


def robot_channels(
    sim: Simulation,
    robot: LoadedRobot | LoadedWorld,
    namespace: str,
    command_topic: Callable[[str], str],
    report: Reporter,
    check_name: Callable[[str, str], str],
) -> tuple[RobotChannels, ...]:
    """Every robot's channels, in the world's order: one robot's topics under ``namespace``,
    a world's robots under their own (one global ``/tf``); ``command_topic`` maps a namespace
    to its joint command topic, ``check_name(name, what)`` validates a ROS name. Two robots
    claiming one topic raise :class:`SessionConfigError`."""
    if isinstance(robot, LoadedRobot):
        return (
            RobotChannels(
                sim,
                namespace,
                "",
                robot.description,
                robot.control,
                _topics(namespace, None, command_topic(namespace), check_name),
                description_text(robot.description, robot.sources, robot.mjcf),
                report,
            ),
        )
    out = tuple(
        RobotChannels(
            sim,
            view.namespace,
            view.prefix,
            view.description,
            view.control,
            _topics(view.namespace, TF, command_topic(view.namespace), check_name),
            description_text(view.description, view.sources, robot.mjcf),
            report,
        )
        for view in robot.robots
    )
    owner: dict[str, str] = {}
    for channels in out:
        topics = channels.topics
        for topic in (
            topics.joint_states,
            topics.joint_command,
            topics.joint_trajectory,
            topics.robot_description,
            *topics.forward.values(),
        ):
            if topic in owner:
                raise SessionConfigError(
                    f"topic {topic} is robot {channels.namespace or '(no namespace)'!r}'s and "
                    f"robot {owner[topic] or '(no namespace)'!r}'s: give each robot its own "
                    "(a relative joint_command_topic lives under each namespace)"
                )
            owner[topic] = channels.namespace
    return out
