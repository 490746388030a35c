"""Passive joints: when a robot file declares which of its joints are actuated (``<ros2_control>``
joints, ``<transmission>`` elements, a drive plugin's wheel joints), the other joints get no
actuator and move freely (casters, a robot's unlisted wheels), as in Gazebo. A file that
declares none keeps every controllable joint actuated. A joint the caller names in a ``control``
mapping is actuated whatever the file says."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from lxml import etree

from harness.models.description import ControlMode, RobotModel

__all__ = ["declared_actuated", "drop_passive", "transmission_joints"]


def transmission_joints(root: etree._Element) -> tuple[str, ...]:
    """The joints the file's ``<transmission>`` elements name (ROS 1 and ROS 2 style)."""
    names = [
        (joint.get("name") or "").strip()
        for transmission in root.iter("transmission")
        for joint in transmission.iter("joint")
    ]
    return tuple(dict.fromkeys(n for n in names if n))


def declared_actuated(
    root: etree._Element, description: RobotModel, plugin_wheels: Iterable[str]
) -> frozenset[str]:
    """Every joint the file declares actuated (empty: the file declares none)."""
    declared = set(transmission_joints(root)) | set(plugin_wheels)
    if description.ros2_control is not None:
        declared |= set(description.ros2_control.joints)
    return frozenset(declared)


def drop_passive(
    modes: Mapping[str, ControlMode],
    declared: frozenset[str],
    requested: ControlMode | str | Mapping[str, ControlMode | str],
) -> dict[str, ControlMode]:
    """``modes`` without the joints the file leaves undeclared (unless ``requested`` names
    them); ``modes`` unchanged when the file declares no actuated joint."""
    if not declared:
        return dict(modes)
    named = set(requested) if isinstance(requested, Mapping) else set()
    return {j: m for j, m in modes.items() if j in declared or j in named}
