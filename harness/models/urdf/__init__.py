"""URDF: read into :class:`~harness.models.RobotModel` and into the XML MuJoCo's importer gets,
read leniently as urdfdom does, with its ``<ros2_control>`` blocks and Gazebo surface tags.
"""

from harness.models.urdf.reader import (
    JOINT_TYPES,
    REPAIR_BOUNDINERTIA,
    REPAIR_BOUNDMASS,
    HarnessExtension,
    PreparedURDF,
    harness_extension,
    mujoco_urdf_xml,
    read_urdf,
    urdf_from_element,
)

__all__ = [
    "JOINT_TYPES",
    "REPAIR_BOUNDINERTIA",
    "REPAIR_BOUNDMASS",
    "HarnessExtension",
    "PreparedURDF",
    "harness_extension",
    "mujoco_urdf_xml",
    "read_urdf",
    "urdf_from_element",
]
