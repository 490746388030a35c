"""Simulated sensors: cameras (RGB, depth), lidars, IMUs, force-torque and contact sensors,
declared in the robot and world files (URDF ``<gazebo>``, SDF ``<sensor>``, MJCF cameras and
sites by name) or in a ``sensors:`` list, producing ROS messages at steps of simulation time.

Each sensor kind has its own module; :class:`SensorSuite` is the session's interface (what is
due at a step, ``/tf_static``, metadata, state interfaces for controllers). Knows nothing of
sockets or MCAP.

The room's rule: **a new sensor is one module in this room and touches no core file.** The
module defines its options record (a frozen :class:`SensorOptions` dataclass of the keys only
its kind takes, validating them) and registers a :class:`SensorKind` (:func:`register_kind`:
its type, the Gazebo/SDF ``<sensor type>`` spellings, outputs, default rate and topics, what
it reads from a ``<sensor>`` element, how it is built on a mount, its options record); the
declaration readers and the suite find it by walking this package
(:mod:`~harness.sensors.registry`). A type no module registers is one line naming it and the
known types; a key of another kind (a lidar's ``samples`` on a camera) is one line naming it
and the kind's options. A kind whose sensors declare ``state_interfaces`` (and
``interface_values(view)``) feeds controllers, as the IMU feeds ``imu_sensor_broadcaster``.
"""

from harness.sensors.base import Sensor, SensorTopic, View
from harness.sensors.camera import CameraOptions, CameraSensor
from harness.sensors.contact import ContactOptions, ContactSensor
from harness.sensors.declare import declared_in_sources, sensors_from_sdf, sensors_from_urdf
from harness.sensors.errors import (
    RenderBackendError,
    SensorConfigError,
    SensorError,
    UnknownSensorType,
)
from harness.sensors.force_torque import ForceTorqueOptions, ForceTorqueSensor
from harness.sensors.ground_truth import GroundTruthOptions
from harness.sensors.hook import record_metadata, sensor_interfaces, session_sensors
from harness.sensors.imu import ImuOptions, ImuSensor
from harness.sensors.lidar import LidarOptions, LidarSensor
from harness.sensors.messages import TYPE_TF, png_bytes
from harness.sensors.options import NoOptions, SensorOptions
from harness.sensors.registry import Mounted, SensorKind, kind_of, known_types, register_kind
from harness.sensors.render import OffscreenRenderer, RendererInfo, contexts_created
from harness.sensors.spec import SensorSpec
from harness.sensors.suite import (
    METADATA_RECORD,
    TOPIC_TF_STATIC,
    Due,
    RobotMount,
    SensorStateInterfaces,
    SensorSuite,
)

__all__ = [
    "METADATA_RECORD",
    "SENSOR_TYPES",
    "TOPIC_TF_STATIC",
    "TYPE_TF",
    "CameraOptions",
    "CameraSensor",
    "ContactOptions",
    "ContactSensor",
    "Due",
    "ForceTorqueOptions",
    "ForceTorqueSensor",
    "GroundTruthOptions",
    "ImuOptions",
    "ImuSensor",
    "LidarOptions",
    "LidarSensor",
    "Mounted",
    "NoOptions",
    "OffscreenRenderer",
    "RenderBackendError",
    "RendererInfo",
    "RobotMount",
    "Sensor",
    "SensorConfigError",
    "SensorError",
    "SensorKind",
    "SensorOptions",
    "SensorSpec",
    "SensorStateInterfaces",
    "SensorSuite",
    "SensorTopic",
    "UnknownSensorType",
    "View",
    "contexts_created",
    "declared_in_sources",
    "kind_of",
    "known_types",
    "png_bytes",
    "record_metadata",
    "register_kind",
    "sensor_interfaces",
    "sensors_from_sdf",
    "sensors_from_urdf",
    "session_sensors",
]


def __getattr__(name: str) -> object:
    if name == "SENSOR_TYPES":  # the registered types, found on first use
        return known_types()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
