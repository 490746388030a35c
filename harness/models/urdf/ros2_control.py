"""The ``<ros2_control>`` blocks of a URDF: which joints a robot's hardware drives, through
which command and state interfaces, from which ``initial_value``, with which hardware plugin.

The harness simulates the hardware: the blocks decide a joint's default control mode (a joint
commanded only through ``velocity`` or ``effort`` gets that mode) and the initial configuration
(``initial_value`` of the ``position`` state interface), and the controllers read them later.
A hardware plugin that stands for a real driver (not a mock or a simulator's plugin) is
replaced by the simulation with a :class:`HardwareReplacedWarning` naming it.

Mimic joints: a URDF ``<mimic>`` is the law; a ``<ros2_control>`` joint's ``mimic`` parameter
(``<param name="mimic">leader</param>`` with ``multiplier``, the Humble syntax that
gazebo_ros2_control and gz_ros2_control read: the follower takes ``multiplier`` times its
leader's command under each of the leader's interfaces) gives a joint without ``<mimic>`` the
same law (:func:`add_control_mimics`), so it follows under every interface.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal

from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.errors import ModelStructureError
from harness.models.files.xmlsafe import describe
from harness.vocabulary import ControlMode

__all__ = [
    "SIMULATED_PLUGINS",
    "ControlBlock",
    "ControlInterface",
    "ControlJoint",
    "HardwareReplacedWarning",
    "Ros2Control",
    "add_control_mimics",
    "interface_modes",
    "parse_ros2_control",
    "warn_replaced_hardware",
]

SIMULATED_PLUGINS: frozenset[str] = frozenset(
    {
        "mock_components/GenericSystem",
        "fake_components/GenericSystem",
        "gazebo_ros2_control/GazeboSystem",
        "ign_ros2_control/IgnitionSystem",
        "gz_ros2_control/GazeboSimSystem",
        "franka_ign_ros2_control/IgnitionSystem",
        "mujoco_ros2_control/MujocoSystem",
    }
)
"""Hardware plugins that are themselves a mock or a simulation: the harness stands in for them
without a notice."""


class HardwareReplacedWarning(UserWarning):
    """A ``<ros2_control>`` hardware plugin (a real robot's driver) is replaced by the
    simulation."""


@dataclass(frozen=True)
class ControlInterface:
    """A command or state interface (``position``, ``velocity``, ``effort``, ...) and its
    ``<param>`` values (``initial_value``, ``min``, ``max``) as written."""

    name: str
    params: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def initial_value(self) -> float | None:
        """The ``initial_value`` parameter as a number (None when absent)."""
        text = self.params.get("initial_value")
        return None if text is None else float(text)


@dataclass(frozen=True)
class ControlJoint:
    """A joint of a ``<ros2_control>`` block with its interfaces in declaration order."""

    name: str
    command_interfaces: tuple[ControlInterface, ...] = ()
    state_interfaces: tuple[ControlInterface, ...] = ()
    params: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

    @property
    def initial_position(self) -> float | None:
        """``initial_value`` of the ``position`` state interface (None when absent)."""
        for interface in self.state_interfaces:
            if interface.name == "position":
                return interface.initial_value
        return None

    @property
    def command_names(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.command_interfaces)


@dataclass(frozen=True)
class ControlBlock:
    """One ``<ros2_control name= type=>`` element: its hardware ``plugin`` and parameters,
    joints, sensors and GPIOs (names only for the last two)."""

    name: str
    type: Literal["system", "actuator", "sensor"] | str
    plugin: str | None
    hardware_params: Mapping[str, str]
    joints: tuple[ControlJoint, ...]
    sensors: tuple[str, ...] = ()
    gpios: tuple[str, ...] = ()

    @property
    def simulated(self) -> bool:
        """Whether the plugin is a mock or a simulator's (see :data:`SIMULATED_PLUGINS`)."""
        return self.plugin is None or self.plugin in SIMULATED_PLUGINS


@dataclass(frozen=True)
class Ros2Control:
    """Every ``<ros2_control>`` block of a description, in document order."""

    blocks: tuple[ControlBlock, ...]

    @property
    def joints(self) -> Mapping[str, ControlJoint]:
        """Joint name -> its entry (the first block that names it wins)."""
        out: dict[str, ControlJoint] = {}
        for block in self.blocks:
            for joint in block.joints:
                out.setdefault(joint.name, joint)
        return MappingProxyType(out)

    @property
    def initial_positions(self) -> Mapping[str, float]:
        """Joint -> ``initial_value`` of its ``position`` state interface, where given."""
        return MappingProxyType(
            {
                name: value
                for name, joint in self.joints.items()
                if (value := joint.initial_position) is not None
            }
        )

    @property
    def replaced_plugins(self) -> tuple[str, ...]:
        """The hardware plugins the simulation stands in for that are real drivers."""
        return tuple(b.plugin for b in self.blocks if b.plugin is not None and not b.simulated)


def _params(element: etree._Element) -> Mapping[str, str]:
    return MappingProxyType(
        {
            str(p.get("name")): (p.text or "").strip()
            for p in element.findall("param")
            if p.get("name")
        }
    )


def _interfaces(joint: etree._Element, tag: str, source: str) -> tuple[ControlInterface, ...]:
    out = []
    for element in joint.findall(tag):
        name = element.get("name")
        if not name:
            raise ModelStructureError(f"{source}: {describe(element)}: no name attribute")
        interface = ControlInterface(name, _params(element))
        text = interface.params.get("initial_value")
        if text is not None:
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise ModelStructureError(
                    f"{source}: {describe(joint)}: {tag} {name!r}: initial_value {text!r} is "
                    "not a finite number"
                )
        out.append(interface)
    return tuple(out)


def parse_ros2_control(root: etree._Element, source: str) -> Ros2Control | None:
    """The ``<ros2_control>`` blocks directly under the URDF ``<robot>`` (None if none)."""
    blocks = []
    for element in root.findall("ros2_control"):
        hardware = element.find("hardware")
        plugin = None
        params: Mapping[str, str] = MappingProxyType({})
        if hardware is not None:
            plugin_el = hardware.find("plugin")
            if plugin_el is not None and (plugin_el.text or "").strip():
                plugin = (plugin_el.text or "").strip()
            params = _params(hardware)
        joints = []
        for joint in element.findall("joint"):
            name = joint.get("name")
            if not name:
                raise ModelStructureError(f"{source}: {describe(joint)}: no name attribute")
            joints.append(
                ControlJoint(
                    name,
                    _interfaces(joint, "command_interface", source),
                    _interfaces(joint, "state_interface", source),
                    _params(joint),
                )
            )
        blocks.append(
            ControlBlock(
                name=str(element.get("name") or ""),
                type=str(element.get("type") or "system"),
                plugin=plugin,
                hardware_params=params,
                joints=tuple(joints),
                sensors=tuple(str(s.get("name")) for s in element.findall("sensor")),
                gpios=tuple(str(g.get("name")) for g in element.findall("gpio")),
            )
        )
    return Ros2Control(tuple(blocks)) if blocks else None


def interface_modes(
    control: Ros2Control | None, joints: Iterable[str], named: Iterable[str] = ()
) -> Mapping[str, ControlMode]:
    """Default control modes the ``<ros2_control>`` declares: a joint among ``joints`` (not
    among ``named``, the joints whose mode the caller chose) whose command interfaces lack
    ``position`` but have ``velocity`` or ``effort`` gets the first of those it declares."""
    if control is None:
        return MappingProxyType({})
    chosen = set(named)
    declared = control.joints
    out: dict[str, ControlMode] = {}
    for name in joints:
        entry = declared.get(name)
        if entry is None or name in chosen or "position" in entry.command_names:
            continue
        for interface in entry.command_names:
            if interface == "velocity":
                out[name] = ControlMode.VELOCITY
                break
            if interface == "effort":
                out[name] = ControlMode.EFFORT
                break
    return MappingProxyType(out)


def warn_replaced_hardware(control: Ros2Control | None, source: str) -> None:
    """One :class:`HardwareReplacedWarning` per real-driver plugin of ``control``."""
    if control is None:
        return
    for block in control.blocks:
        if block.plugin is not None and not block.simulated:
            warnings.warn(
                f'{source}: <ros2_control name="{block.name}"> hardware plugin '
                f"{block.plugin!r} is a real driver; the simulation stands in for it",
                HardwareReplacedWarning,
                stacklevel=3,
            )


def _number(text: str, what: str) -> str:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ModelStructureError(f"{what} {text!r} is not a finite number")
    return repr(value)


def add_control_mimics(root: etree._Element, source: str) -> None:
    """Give each URDF joint that a ``<ros2_control>`` joint's ``mimic`` parameter makes a
    follower (and that has no ``<mimic>`` of its own) the ``<mimic joint= multiplier=
    offset=>`` element of that law (``multiplier`` default 1, ``offset`` default 0), in
    ``root`` itself: the description and the simulation then read one law. A parameter
    naming no other joint of the robot is one :class:`ModelStructureError` naming the file
    and joint."""
    joints = {str(j.get("name")): j for j in root.findall("joint")}
    for block in root.findall("ros2_control"):
        for entry in block.findall("joint"):
            params = _params(entry)
            leader = params.get("mimic")
            if not leader:
                continue
            name = str(entry.get("name") or "")
            where = f'{source}: <ros2_control name="{block.get("name") or ""}"> joint {name!r}'
            if leader not in joints or leader == name or name not in joints:
                raise ModelStructureError(
                    f"{where}: mimic {leader!r} is not another joint of the robot"
                )
            follower = joints[name]
            if follower.find("mimic") is not None:
                continue  # the URDF's own law
            etree.SubElement(
                follower,
                "mimic",
                {
                    "joint": leader,
                    "multiplier": _number(params.get("multiplier", "1"), f"{where}: multiplier"),
                    "offset": _number(params.get("offset", "0"), f"{where}: offset"),
                },
            )
