"""Robot descriptions: URDF (plain or xacro), SDF and MJCF into one `RobotModel` and a compiled
MuJoCo model."""

from harness.models.build import (
    DEMO_URDF,
    SCENES,
    LoadedRobot,
    load_description,
    load_robot,
    load_world,
)
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
from harness.models.ros2_control import HardwareReplacedWarning, Ros2Control
from harness.models.world import (
    DuplicateNamespaceError,
    InvalidNamespaceError,
    JointAddress,
    LoadedRobotView,
    LoadedWorld,
    PoseLike,
    RobotSpec,
    WorldObject,
)
from harness.models.xacro import UnusedRobotArgWarning, XacroOrigin, expand_xacro

__all__ = [
    "CONTROL_MODES",
    "DEMO_URDF",
    "SCENES",
    "ControlMode",
    "DuplicateNamespaceError",
    "Geometry",
    "HardwareReplacedWarning",
    "Inertial",
    "InvalidNamespaceError",
    "Joint",
    "JointAddress",
    "JointLimits",
    "Link",
    "LoadedRobot",
    "LoadedRobotView",
    "LoadedWorld",
    "Mimic",
    "ModelFrame",
    "Pose",
    "PoseLike",
    "RobotModel",
    "RobotSpec",
    "Ros2Control",
    "Shape",
    "UnusedRobotArgWarning",
    "WorldObject",
    "XacroOrigin",
    "expand_xacro",
    "load_description",
    "load_robot",
    "load_world",
]
