"""Which joints a robot file's drive plugins drive (Gazebo Classic ``libgazebo_ros_diff_drive.so``,
gz-sim ``DiffDrive``): they are velocity-driven by default, as the plugins drive them. The
plugins themselves become controllers in :mod:`harness.controllers.gazebo_plugins`."""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

from lxml import etree

from harness.models.description import ControlMode

__all__ = [
    "DIFF_DRIVE_PLUGINS",
    "drive_plugin_elements",
    "is_diff_drive",
    "plugin_modes",
    "plugin_wheels",
]

DIFF_DRIVE_PLUGINS = (
    "libgazebo_ros_diff_drive.so",
    "gz-sim-diff-drive-system",
    "libgz-sim-diff-drive-system.so",
    "ignition-gazebo-diff-drive-system",
    "libignition-gazebo-diff-drive-system.so",
    "libignition-gazebo6-diff-drive-system.so",
)
"""Plugin file names of differential drives (the first: Gazebo Classic; the others: gz-sim)."""


_VERSIONED = re.compile(r"(lib)?(gz-sim|ignition-gazebo)\d*-diff-drive-system(\.so)?")


def is_diff_drive(filename: str) -> bool:
    """Whether a plugin file name is a differential drive's (gz-sim's also with its version,
    ``libgz-sim8-diff-drive-system.so``)."""
    return filename in DIFF_DRIVE_PLUGINS or _VERSIONED.fullmatch(filename) is not None


def drive_plugin_elements(root: etree._Element) -> list[etree._Element]:
    """The ``<plugin>`` elements of differential drives anywhere in the file."""
    return [p for p in root.iter("plugin") if is_diff_drive(p.get("filename", ""))]


def plugin_wheels(root: etree._Element) -> tuple[str, ...]:
    """The wheel joints the file's drive plugins name (ROS 1: ``<leftJoint>``...)."""
    wheels: list[str] = []
    for plugin in drive_plugin_elements(root):
        for tag in ("left_joint", "right_joint", "leftJoint", "rightJoint"):
            wheels += [
                (e.text or "").strip() for e in plugin.findall(tag) if (e.text or "").strip()
            ]
    return tuple(dict.fromkeys(wheels))


def plugin_modes(
    modes: Mapping[str, ControlMode],
    wheels: Iterable[str],
    requested: ControlMode | str | Mapping[str, ControlMode | str],
) -> dict[str, ControlMode]:
    """``modes`` with the plugins' wheels velocity-driven where the caller left the default
    (``control="position"``, or a mapping that does not name the wheel)."""
    out = dict(modes)
    for wheel in wheels:
        named = isinstance(requested, Mapping) and wheel in requested
        chose = isinstance(requested, str) and requested != "position"
        if wheel in out and out[wheel] == "position" and not named and not chose:
            out[wheel] = ControlMode.VELOCITY
    return out
