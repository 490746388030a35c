"""The graph set-up a session core does once, before its first step.

What it publishes (:func:`published_topics`: every robot's topics, ``/clock``,
``/rosout``), one TF tree per pair of ``/tf`` and ``/tf_static`` topics (:func:`tf_trees`),
the advertising of those topics (:func:`advertise_and_subscribe`; the command topics are the
controllers'), and the latched messages published at step 0: robot descriptions and static
transforms (:func:`publish_latched`). The per-step publishing stays
in :class:`~harness.session.core.SessionCore`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from functools import partial
from typing import Any

import mujoco

from harness.sensors import TOPIC_TF_STATIC
from harness.sensors.suite import SensorSuite
from harness.session.core.bridge import Graph, Publisher
from harness.session.core.channels import CLOCK, ROSOUT, RobotChannels, robot_frames
from harness.session.core.tf import TfTree
from harness.session.core.topics import (
    HARNESS_NODE,
    TYPE_CLOCK,
    TYPE_LOG,
    TYPE_STRING,
    TYPE_TF,
    TopicDef,
    robot_topic_defs,
)
from harness.sim import Simulation

__all__ = [
    "TfTopics",
    "advertise_and_subscribe",
    "publish_latched",
    "published_topics",
    "tf_trees",
]

TfTopics = tuple[str, str, TfTree]
"""A ``/tf`` topic, its ``/tf_static`` topic and the tree of the robots publishing there."""


def published_topics(
    robots: Iterable[RobotChannels], *, joint_states: bool, tf: bool, clock: bool
) -> tuple[TopicDef, ...]:
    """Every topic a core publishes, in advertising order (``joint_states``, ``tf``,
    ``clock``: whether those are published at all)."""
    defs: list[TopicDef] = []
    for channels in robots:
        topics = channels.topics
        defs += robot_topic_defs(
            channels.namespace,
            joint_states=topics.joint_states if joint_states else None,
            tf=topics.tf if tf else None,
            tf_static=topics.tf_static,
            robot_description=topics.robot_description,
        )
    if clock:
        defs.append(TopicDef(CLOCK, TYPE_CLOCK, HARNESS_NODE))
    defs.append(TopicDef(ROSOUT, TYPE_LOG, HARNESS_NODE))
    return tuple(defs)


def tf_trees(model: mujoco.MjModel, robots: Iterable[RobotChannels]) -> tuple[TfTopics, ...]:
    """One TF tree per pair of ``/tf`` and ``/tf_static`` topics the robots publish on, in
    the robots' order."""
    by_topics: dict[tuple[str, str], list[RobotChannels]] = {}
    for channels in robots:
        key = (channels.topics.tf, channels.topics.tf_static)
        by_topics.setdefault(key, []).append(channels)
    return tuple(
        (tf, tf_static, TfTree(model, (robot_frames(r) for r in rs)))
        for (tf, tf_static), rs in by_topics.items()
    )


def advertise_and_subscribe(graph: Graph, published: Iterable[TopicDef]) -> None:
    """Advertise every published topic. The robots' command topics are their controllers'
    (:class:`~harness.session.control.ControlHost` subscribes them, the harness's own ones
    too: one command path)."""
    for defined in published:
        graph.advertise(defined.name, defined.type, node=defined.node, latch=defined.latched)


def publish_latched(
    publisher: Publisher,
    sim: Simulation,
    trees: Sequence[TfTopics],
    robots: Iterable[RobotChannels],
    sensors: SensorSuite | None,
) -> None:
    """Publish every robot's latched description and static transforms (the sensors'
    frames with those on the global ``/tf_static``, or alone when no robot publishes there)."""
    poses = sim.link_poses()
    sensor_frames = sensors is not None
    for _, tf_static, tree in trees:
        # one latched message per topic: a late subscriber gets only the last one
        with_sensors = sensor_frames and tf_static == TOPIC_TF_STATIC
        sensor_frames = sensor_frames and not with_sensors
        build = partial(_static_tf, tree, poses, sim, sensors if with_sensors else None)
        publisher.publish(tf_static, TYPE_TF, build, latch=True)
    for channels in robots:
        text = channels.description_text
        publisher.publish(
            channels.topics.robot_description,
            TYPE_STRING,
            lambda text=text: {"data": text},  # type: ignore[misc]
            latch=True,
        )
    if sensor_frames and sensors is not None:
        publisher.publish(TOPIC_TF_STATIC, TYPE_TF, sensors.static_tf, latch=True)


def _static_tf(
    tree: TfTree, poses: Mapping[str, Any], sim: Simulation, sensors: SensorSuite | None
) -> dict[str, Any]:
    msg = tree.message(tree.static, poses, sim.sim_time_ns)
    if sensors is not None:
        transforms = sensors.static_tf(sim.sim_time_ns)["transforms"]
        msg["transforms"] = [*msg["transforms"], *transforms]
    return msg
