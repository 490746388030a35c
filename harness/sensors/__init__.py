"""Simulated sensors: cameras (RGB, depth), lidars, IMUs, force-torque and contact sensors,
declared in the robot and world files (URDF ``<gazebo>``, SDF ``<sensor>``, MJCF cameras and
sites by name) or in a ``sensors:`` list, producing ROS messages at steps of simulation time.

Each sensor kind has its own module; :class:`SensorSuite` is the session's interface (what is
due at a step, ``/tf_static``, metadata). Knows nothing of sockets or MCAP.
"""

from harness.sensors.base import Output, Sensor, View
from harness.sensors.camera import CameraSensor
from harness.sensors.contact import ContactSensor
from harness.sensors.declare import declared_in_sources, sensors_from_sdf, sensors_from_urdf
from harness.sensors.errors import RenderBackendError, SensorConfigError, SensorError
from harness.sensors.force_torque import ForceTorqueSensor
from harness.sensors.imu import ImuSensor
from harness.sensors.lidar import LidarSensor
from harness.sensors.messages import TYPE_TF
from harness.sensors.render import OffscreenRenderer, RendererInfo, contexts_created
from harness.sensors.spec import SENSOR_TYPES, SensorSpec
from harness.sensors.suite import (
    METADATA_RECORD,
    TOPIC_TF_STATIC,
    Due,
    RobotMount,
    SensorSuite,
)

__all__ = [
    "METADATA_RECORD",
    "SENSOR_TYPES",
    "TOPIC_TF_STATIC",
    "TYPE_TF",
    "CameraSensor",
    "ContactSensor",
    "Due",
    "ForceTorqueSensor",
    "ImuSensor",
    "LidarSensor",
    "OffscreenRenderer",
    "Output",
    "RenderBackendError",
    "RendererInfo",
    "RobotMount",
    "Sensor",
    "SensorConfigError",
    "SensorError",
    "SensorSpec",
    "SensorSuite",
    "View",
    "contexts_created",
    "declared_in_sources",
    "sensors_from_sdf",
    "sensors_from_urdf",
]
