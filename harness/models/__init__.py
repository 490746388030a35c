"""Robot descriptions: URDF, SDF and MJCF into one `RobotModel` and a compiled MuJoCo model."""

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
    "ControlMode",
    "Geometry",
    "Inertial",
    "Joint",
    "JointLimits",
    "Link",
    "Mimic",
    "ModelFrame",
    "Pose",
    "RobotModel",
    "Shape",
]
