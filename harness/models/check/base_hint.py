"""The hint ``harness check-model`` gives a mobile robot checked with a fixed base: its wheels
(velocity-driven joints that turn without limits, as a drive plugin or a ``<ros2_control>``
velocity interface drives them) spin in the air while the base is held where it was put, so
the check says nothing about driving. ``--base floating`` (``load_robot(base="floating")``)
sets it down on the floor."""

from __future__ import annotations

import math
from typing import Any

from harness.models.description import ControlMode

__all__ = ["floating_base_hint", "wheel_joints"]


def _unlimited(joint: Any) -> bool:
    if joint.type == "continuous":
        return True
    if joint.type != "revolute":
        return False
    lower, upper = joint.limits.lower, joint.limits.upper
    return lower is None or upper is None or not (math.isfinite(lower) and math.isfinite(upper))


def wheel_joints(loaded: Any) -> tuple[str, ...]:
    """The joints of a loaded robot driven as wheels: velocity-driven and unlimited."""
    control = loaded.control
    return tuple(
        joint.name
        for joint in loaded.description.joints
        if control.get(joint.name) == ControlMode.VELOCITY and _unlimited(joint)
    )


def floating_base_hint(loaded: Any) -> str | None:
    """One line suggesting ``--base floating`` for a fixed-base robot with wheels, else
    None."""
    if getattr(loaded, "base", "fixed") == "floating":
        return None
    wheels = wheel_joints(loaded)
    if not wheels:
        return None
    declared = loaded.description.ros2_control
    by_interface = declared is not None and all(w in declared.joints for w in wheels)
    why = (
        "its <ros2_control> commands them by velocity"
        if by_interface
        else "a drive plugin drives them"
    )
    return (
        f"{', '.join(wheels)} turn as wheels ({why}) but the base is fixed to the world, "
        "held where it was put: a mobile robot needs --base floating "
        "(load_robot(base='floating'))"
    )
