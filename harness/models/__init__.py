"""Robot descriptions: URDF, SDF and MJCF into one `RobotModel` and a compiled MuJoCo model."""

from harness.models.build import DEMO_URDF, SCENES, LoadedRobot, load_description, load_robot
from harness.models.description import (
    CONTROL_MODES,
    ControlMode,
    Geometry,
    Inertial,
    Joint,
    JointLimits,
    Link,
    Mimic,
    ModelFrame,
    Pose,
    RobotModel,
    Shape,
)

__all__ = [
    "CONTROL_MODES",
    "DEMO_URDF",
    "SCENES",
    "ControlMode",
    "Geometry",
    "Inertial",
    "Joint",
    "JointLimits",
    "Link",
    "LoadedRobot",
    "Mimic",
    "ModelFrame",
    "Pose",
    "RobotModel",
    "Shape",
    "load_description",
    "load_robot",
]
