"""Robot descriptions: URDF, SDF and MJCF into one `RobotModel` and a compiled MuJoCo model."""

from harness.models.description import (
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
