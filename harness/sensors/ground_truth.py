"""Ground truth odometry, as Gazebo's ``libgazebo_ros_p3d.so`` (and gz-sim's
``OdometryPublisher``) give it: ``nav_msgs/msg/Odometry`` of the mounted frame's true pose in
the world, with its linear velocity in the world frame and its angular velocity, stamped in
``frame_id`` (default ``world``) with ``child_frame_id`` the mount link. No noise, no drift:
the reference a wheel-odometry estimate is judged against. Default topic
``ground_truth/odom``."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from harness.sensors.base import F64, Mount, SensorTopic, View, cross, quat_of
from harness.sensors.messages import header
from harness.sensors.options import SensorOptions
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.spec import SensorSpec

__all__ = ["TYPE_ODOMETRY", "GroundTruthOptions", "GroundTruthSensor"]

TYPE_ODOMETRY = "nav_msgs/msg/Odometry"


@dataclass(frozen=True)
class GroundTruthOptions(SensorOptions):
    """Ground truth has no options of its own (its topic and frame are the spec's)."""


def _xyz(v: F64) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


class GroundTruthSensor:
    """The true pose and velocity of ``mount`` (see the module docstring)."""

    def __init__(
        self, spec: SensorSpec, mount: Mount, topics: Mapping[str, str], frame_id: str
    ) -> None:
        self.spec = spec
        self.mount = mount
        self.frame_id = frame_id
        self.outputs: tuple[SensorTopic, ...] = (
            SensorTopic("odom", topics["odom"], TYPE_ODOMETRY),
        )

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The ``Odometry`` builder at this step."""

        def odom() -> dict[str, Any]:
            position, rotation = self.mount.world(view.data)
            velocity = np.zeros(6)
            mujoco.mj_objectVelocity(
                view.model, view.data, mujoco.mjtObj.mjOBJ_XBODY, self.mount.body, velocity, 0
            )
            omega = velocity[:3]
            linear = velocity[3:] + cross(omega, position - view.data.xpos[self.mount.body])
            quat = quat_of(rotation)
            return {
                "header": header(view.sim_time_ns, self.frame_id),
                "child_frame_id": self.mount.body_name,
                "pose": {
                    "pose": {
                        "position": _xyz(position),
                        "orientation": {
                            "x": float(quat[1]),
                            "y": float(quat[2]),
                            "z": float(quat[3]),
                            "w": float(quat[0]),
                        },
                    },
                    "covariance": [0.0] * 36,
                },
                "twist": {
                    "twist": {"linear": _xyz(linear), "angular": _xyz(omega)},
                    "covariance": [0.0] * 36,
                },
            }

        return {"odom": odom}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """None: the world frame is no child of the mount link."""
        return []


def _topics(topic: str, base: str) -> dict[str, str]:
    return {"odom": topic or "ground_truth/odom"}


def _build(spec: SensorSpec, at: Mounted) -> GroundTruthSensor:
    # stamped in the world (unprefixed), not in the sensor frame
    return GroundTruthSensor(spec, at.mount, at.topics, spec.frame_id or "world")


register_kind(
    SensorKind("ground_truth", ("odom",), 50.0, _build, topics=_topics, options=GroundTruthOptions)
)
