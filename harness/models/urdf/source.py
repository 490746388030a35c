"""A robot reference (a path, ``package://pkg/file``, a ``.urdf`` or a xacro file with its
arguments) read into the URDF element the loader builds from, with what the description
declares for control (``<ros2_control>``).

The loader (:mod:`harness.models.build.load`) calls :func:`locate` for the file and
:func:`read_urdf_source` for a URDF or xacro robot; the rest of the build does not know
whether the URDF was expanded.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

from harness.models.description import ControlMode, RobotModel
from harness.models.errors import ModelStructureError, XacroError
from harness.models.files.confine import confinement
from harness.models.files.resolve import PackageMap, resolve_uri
from harness.models.files.xmlsafe import parse_xml
from harness.models.urdf.lenient import LoadNote, read_lenient_xml
from harness.models.urdf.reader import urdf_from_element
from harness.models.urdf.ros2_control import (
    add_control_mimics,
    interface_modes,
    parse_ros2_control,
)
from harness.models.xacro.expand import (
    RobotArgs,
    XacroOrigin,
    expand_xacro,
    is_xacro,
    normalize_args,
)

__all__ = [
    "UrdfSource",
    "control_defaults",
    "describe_urdf",
    "initial_keyframes",
    "locate",
    "read_urdf_source",
]


class UrdfSource(NamedTuple):
    """A URDF ready to build: ``path`` (relative references resolve from its folder; for a
    xacro robot the expanded file's name beside the entry file), the parsed ``root``, its
    bytes ``data`` (the expanded text for xacro), ``extra`` sources to record (xacro files
    read, meshes named), the xacro ``origin`` (None for a plain URDF) and the ``notes`` of
    what a lenient read recovered (:func:`harness.models.urdf.lenient.read_lenient_xml`)."""

    path: Path
    root: Any
    data: bytes
    extra: Mapping[str, bytes]
    origin: XacroOrigin | None
    notes: tuple[LoadNote, ...] = ()


def locate(source: str | Path, packages: PackageMap | None = None) -> Path:
    """The file of a robot reference: a path, or ``package://pkg/path`` found by the
    package search (:func:`harness.models.files.resolve.find_package`)."""
    text = str(source)
    if text.startswith("package://"):
        return resolve_uri(
            text, base_dir=Path.cwd(), packages=packages, context="robot", what="robot file"
        )
    path = Path(source)
    if not path.is_file():
        raise ModelStructureError(f"{path}: model file not found")
    return path


def read_urdf_source(
    path: Path,
    *,
    robot_args: RobotArgs | Iterable[str] | None = None,
    packages: PackageMap | None = None,
    reference: str | None = None,
    strict: bool = False,
) -> UrdfSource:
    """Read (and for a xacro file expand with ``robot_args``) the URDF at ``path``; a plain
    URDF is read leniently (a wrong XML declaration or trailing content is recovered with a
    note) unless ``strict``."""
    if not is_xacro(path):
        if normalize_args(robot_args):
            raise XacroError(
                f"{path}: robot arguments {sorted(normalize_args(robot_args))} given, but the "
                "file is not a xacro file (.xacro, or a root declaring xmlns:xacro)"
            )
        root, data, notes = read_lenient_xml(path, strict=strict)
        return UrdfSource(path, root, data, MappingProxyType({}), None, notes)
    if confinement() is not None:  # xacro runs code: never on a recording's files
        raise XacroError(
            f"{path.name}: a xacro source is never expanded when a model is rebuilt from a "
            "recording"
        )
    expansion = expand_xacro(path, robot_args, packages=packages, reference=reference)
    root = parse_xml(expansion.urdf, str(path))
    return UrdfSource(
        path.parent / expansion.urdf_name,
        root,
        expansion.urdf,
        expansion.sources,
        expansion.origin,
    )


def describe_urdf(root: Any, source: str, origin: XacroOrigin | None = None) -> RobotModel:
    """The :class:`RobotModel` of a URDF element with its ``<ros2_control>`` blocks and xacro
    origin."""
    add_control_mimics(root, source)
    description = urdf_from_element(root, source)
    return dataclasses.replace(
        description, ros2_control=parse_ros2_control(root, source), xacro=origin
    )


def initial_keyframes(
    keys: Mapping[str, Mapping[str, float]], description: RobotModel
) -> Mapping[str, Mapping[str, float]]:
    """``keys`` (a URDF's ``<harness>`` keyframes) with a ``home`` key made of the
    ``<ros2_control>`` ``initial_value`` positions when the file has no ``home`` of its own
    (joints the model does not drive are left out; mimic followers follow their leader)."""
    control = description.ros2_control
    if control is None or "home" in keys:
        return keys
    joints = {j.name for j in description.controllable_joints}
    home = {j: v for j, v in control.initial_positions.items() if j in joints}
    if not home:
        return keys
    for joint in description.joints:  # mimic followers start where their leader puts them
        lead = home.get(joint.mimic.joint) if joint.mimic is not None else None
        if joint.mimic is not None and lead is not None:
            home[joint.name] = joint.mimic.multiplier * lead + joint.mimic.offset
    return MappingProxyType({**keys, "home": MappingProxyType(home)})


def control_defaults(
    description: RobotModel,
    modes: Mapping[str, ControlMode],
    requested: ControlMode | str | Mapping[str, ControlMode | str],
) -> dict[str, ControlMode]:
    """``modes`` with the ``<ros2_control>`` command interfaces applied to the joints whose
    mode the caller left at the default (``control="position"`` or unnamed in a mapping):
    a joint commanded only through velocity or effort gets that mode."""
    if isinstance(requested, str):
        named: Iterable[str] = () if requested == "position" else modes
    else:
        named = requested
    out = dict(modes)
    declared = interface_modes(description.ros2_control, modes, named)
    out.update({j: m for j, m in declared.items() if out.get(j) == "position"})
    return out
