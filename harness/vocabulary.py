"""Closed vocabularies shared by every layer: one enum per concept, one parse at the boundary.

This module imports only the standard library (the pytest plugin and the CLI build their
``choices`` from it before MuJoCo loads).
"""

from __future__ import annotations

from enum import Enum

__all__ = [
    "BASE_KINDS",
    "CONTROL_MODES",
    "CONTROL_MODE_INPUTS",
    "DYNAMIC_ALIAS",
    "SELF_COLLISION_POLICIES",
    "ControlMode",
    "RobotBase",
    "SelfCollisionPolicy",
]

DYNAMIC_ALIAS = "dynamic"
"""Input spelling of :attr:`ControlMode.POSITION`: the original framework's name, and the
product's "kinematic vs dynamic"."""


class ControlMode(str, Enum):
    """How a controllable joint is driven: ``kinematic`` (qpos written before each step, qvel by
    finite difference) or dynamic through an actuator (``position`` servo, ``velocity`` servo,
    ``effort`` motor). A closed vocabulary: members compare equal to their strings.

    ``dynamic`` (the original framework's name, and the product's "kinematic vs dynamic") is an
    input alias of ``position`` (the robot's dynamic default), accepted by :meth:`parse` and by
    ``ControlMode("dynamic")`` at every boundary (marker, ``--harness-mode``, scenario files,
    ``Session``, ``harness serve --mode``, ``harness replay --mode``); it is never stored.
    """

    KINEMATIC = "kinematic"
    POSITION = "position"
    VELOCITY = "velocity"
    EFFORT = "effort"

    # A member behaves as its string everywhere: printed, formatted, hashed (sets and dict
    # keys mix with plain strings read back from recordings and files).
    def __str__(self) -> str:
        return self.value

    def __repr__(self) -> str:
        return repr(self.value)

    def __hash__(self) -> int:
        return hash(self.value)

    def __format__(self, spec: str) -> str:
        return self.value.__format__(spec)

    @classmethod
    def _missing_(cls, value: object) -> ControlMode | None:
        return cls.POSITION if value == DYNAMIC_ALIAS else None

    @classmethod
    def parse(cls, value: object, where: str = "control mode") -> ControlMode:
        """``value`` as a member (``dynamic`` gives ``POSITION``); a ValueError naming
        ``where`` and the accepted spellings otherwise."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(
                f"{where}: unknown control mode {value!r} (one of {', '.join(CONTROL_MODE_INPUTS)})"
            ) from None


CONTROL_MODES: tuple[ControlMode, ...] = tuple(ControlMode)
CONTROL_MODE_INPUTS: tuple[str, ...] = (*(m.value for m in ControlMode), DYNAMIC_ALIAS)
"""Every accepted spelling of a control mode (argparse ``choices``, schema ``enum``)."""


class _Vocabulary(str, Enum):
    """A closed vocabulary whose members behave as their strings (see :class:`ControlMode`)."""

    def __str__(self) -> str:
        return str(self.value)

    def __repr__(self) -> str:
        return repr(self.value)

    def __hash__(self) -> int:
        return hash(self.value)

    def __format__(self, spec: str) -> str:
        return str(self.value).__format__(spec)


class SelfCollisionPolicy(_Vocabulary):
    """Which pairs of a robot's own links collide (option ``self_collision``, see
    ``harness.models.selfcollision``): ``auto`` (MoveIt-style: adjacent pairs, pairs in
    contact at the initial configuration and pairs nearly always in contact are ignored),
    ``off`` (none: Gazebo's default), ``on`` (every pair but parent/child) or ``srdf`` (the
    SRDF's ``<disable_collisions>``)."""

    AUTO = "auto"
    OFF = "off"
    ON = "on"
    SRDF = "srdf"

    @classmethod
    def parse(cls, value: object, where: str = "self_collision") -> SelfCollisionPolicy:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(
                f"{where}: unknown self_collision {value!r} (one of "
                f"{', '.join(SELF_COLLISION_POLICIES)})"
            ) from None


class RobotBase(_Vocabulary):
    """How a robot's base is held (option ``base``): ``fixed`` to the world or ``floating``
    (a free joint, placed on the floor)."""

    FIXED = "fixed"
    FLOATING = "floating"

    @classmethod
    def parse(cls, value: object, where: str = "base") -> RobotBase:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(
                f"{where}: unknown base {value!r} (one of {', '.join(BASE_KINDS)})"
            ) from None


SELF_COLLISION_POLICIES: tuple[str, ...] = tuple(p.value for p in SelfCollisionPolicy)
"""Every spelling of ``self_collision`` (argparse ``choices``, schema ``enum``)."""
BASE_KINDS: tuple[str, ...] = tuple(b.value for b in RobotBase)
"""Every spelling of ``base`` (argparse ``choices``, schema ``enum``)."""
