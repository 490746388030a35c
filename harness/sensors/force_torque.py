"""Force-torque sensors at a joint (or on a link): ``geometry_msgs/WrenchStamped``.

The wrench is the interaction between the sensor's link (the joint's child) and its parent,
MuJoCo's ``cfrc_int`` (which carries everything below the joint), taken at the sensor
position. ``ft_direction``: ``child_to_parent`` (SDF's default: what the child exerts on the
parent; a hanging mass pulls down) or ``parent_to_child``. ``ft_frame``: expressed in the
``child`` link's axes (SDF's default), the ``parent`` link's or the ``sensor`` frame's."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, get_args

import mujoco
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, cross, noise_rng, quat_of
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import TYPE_WRENCH, header, wrench_msg
from harness.sensors.options import SensorOptions
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.sdf_values import element_noise, element_text
from harness.sensors.spec import SensorSpec

__all__ = ["FT_INTERFACES", "ForceTorqueOptions", "ForceTorqueSensor"]

FtFrame = Literal["child", "parent", "sensor"]
FtDirection = Literal["child_to_parent", "parent_to_child"]

FT_INTERFACES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")
"""A force-torque sensor's state interfaces, in ros2_control's order (what a
``force_torque_sensor_broadcaster`` reads)."""


@dataclass(frozen=True)
class ForceTorqueOptions(SensorOptions):
    """A force-torque sensor's options: ``ft_frame``, the axes its wrench is expressed in (the
    ``child`` link's, the ``parent`` link's or the ``sensor`` frame's), and ``ft_direction``
    (``child_to_parent``: what the child exerts on the parent, or ``parent_to_child``)."""

    ft_frame: FtFrame = "child"
    ft_direction: FtDirection = "child_to_parent"

    def __post_init__(self) -> None:
        if self.ft_frame not in get_args(FtFrame):
            raise SensorConfigError("ft_frame must be child, parent or sensor")
        if self.ft_direction not in get_args(FtDirection):
            raise SensorConfigError("ft_direction must be child_to_parent or parent_to_child")


class ForceTorqueSensor:
    """A force-torque sensor of ``spec`` at ``mount``."""

    def __init__(
        self,
        spec: SensorSpec,
        model: mujoco.MjModel,
        mount: Mount,
        topics: Mapping[str, str],
        frame_id: str,
    ) -> None:
        self.spec = spec
        self.mount = mount
        self.frame_id = frame_id
        self.outputs: tuple[SensorTopic, ...] = (
            SensorTopic("wrench", topics["wrench"], TYPE_WRENCH),
        )
        self._root = int(model.body_rootid[mount.body])
        self._parent = int(model.body_parentid[mount.body])
        self.state_interfaces = FT_INTERFACES

    def values(self, view: View) -> tuple[F64, F64]:
        """(force, torque) in the configured frame and direction."""
        view.forces()
        data, spec = view.data, self.spec
        options = spec.options_as(ForceTorqueOptions)
        body = self.mount.body
        torque_c, force = data.cfrc_int[body, :3], data.cfrc_int[body, 3:]
        position, sensor_rot = self.mount.world(data)
        # cfrc_int is a spatial force at the subtree centre of mass of the root body.
        torque = torque_c + cross(data.subtree_com[self._root] - position, force)
        if options.ft_direction == "child_to_parent":
            force, torque = -force, -torque
        if options.ft_frame == "sensor":
            axes = sensor_rot
        elif options.ft_frame == "parent":
            axes = data.xmat[self._parent].reshape(3, 3)
        else:
            axes = data.xmat[body].reshape(3, 3)
        force, torque = axes.T @ force, axes.T @ torque
        if spec.noise_stddev or spec.noise_mean:
            noise = noise_rng(view.seed, spec.name, view.step).normal(
                spec.noise_mean, spec.noise_stddev, 6
            )
            force, torque = force + noise[:3], torque + noise[3:]
        return force, torque

    def interface_values(self, view: View) -> tuple[float, ...]:
        """The values of :data:`FT_INTERFACES` at this step (those of its message)."""
        force, torque = self.values(view)
        return (*map(float, force), *map(float, torque))

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The ``WrenchStamped`` builder at this step."""

        def wrench() -> dict[str, Any]:
            force, torque = self.values(view)
            return wrench_msg(header(view.sim_time_ns, self.frame_id), force, torque)

        return {"wrench": wrench}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """The sensor frame in the mount link."""
        return [(self.frame_id, self.mount.position, quat_of(self.mount.rotation))]


def _params(sensor: etree._Element, where: str) -> dict[str, Any]:
    ft = sensor.find("force_torque")
    params: dict[str, Any] = {}
    frame = element_text(ft, "frame")
    direction = element_text(ft, "measure_direction")
    if frame:
        params["ft_frame"] = frame
    if direction:
        params["ft_direction"] = direction
    params.update(element_noise(ft, where))
    return params


def _build(spec: SensorSpec, at: Mounted) -> ForceTorqueSensor:
    return ForceTorqueSensor(spec, at.model, at.mount, at.topics, at.frame_id)


register_kind(
    SensorKind(
        "force_torque",
        ("wrench",),
        100.0,
        _build,
        gazebo=("force_torque",),
        params=_params,
        options=ForceTorqueOptions,
    )
)
