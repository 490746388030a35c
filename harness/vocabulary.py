"""Closed vocabularies shared by every layer: one enum per concept, one parse at the boundary.

This module imports only the standard library (the pytest plugin and the CLI build their
``choices`` from it before MuJoCo loads).
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum
from typing import Any

__all__ = [
    "ACTUATIONS",
    "ACTUATION_INPUTS",
    "BASE_KINDS",
    "CLOCK_MODES",
    "CONTROL_MODES",
    "CONTROL_MODE_INPUTS",
    "DYNAMIC_ALIAS",
    "LIMIT_POLICIES",
    "LIMIT_POLICY_KEY",
    "LIMIT_POLICY_OLD_KEY",
    "MESH_COLLISION_MODES",
    "SCHEMA_ENUMS",
    "SELF_COLLISION_POLICIES",
    "Actuation",
    "ClockMode",
    "ControlMode",
    "LimitPolicy",
    "MeshCollisionMode",
    "RobotBase",
    "SelfCollisionPolicy",
    "apply_schema_enums",
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
    ``ControlMode("dynamic")`` at every boundary (marker, scenario files, ``Session``,
    ``harness serve --mode``); it is never stored. The whole-run switch
    (``--harness-actuation``, ``harness replay --actuation``) is :class:`Actuation`.
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
    ``harness.models.build.selfcollision``): ``auto`` (MoveIt-style: adjacent pairs, pairs in
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
        result: SelfCollisionPolicy = _parse(
            cls, value, where, "self_collision", SELF_COLLISION_POLICIES
        )
        return result


class RobotBase(_Vocabulary):
    """How a robot's base is held (option ``base``): ``fixed`` to the world or ``floating``
    (a free joint, placed on the floor)."""

    FIXED = "fixed"
    FLOATING = "floating"

    @classmethod
    def parse(cls, value: object, where: str = "base") -> RobotBase:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        result: RobotBase = _parse(cls, value, where, "base", BASE_KINDS)
        return result


class MeshCollisionMode(_Vocabulary):
    """How a colliding non-convex mesh collides (option ``mesh_collision``, see
    ``harness.models.build.decompose``): ``decompose`` (convex pieces within 2 cm of its
    triangles, as Gazebo collides the triangles) or ``hull`` (MuJoCo's convex hull of the
    whole mesh)."""

    DECOMPOSE = "decompose"
    HULL = "hull"

    @classmethod
    def parse(cls, value: object, where: str = "mesh_collision") -> MeshCollisionMode:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        result: MeshCollisionMode = _parse(
            cls, value, where, "mesh_collision", MESH_COLLISION_MODES
        )
        return result


SELF_COLLISION_POLICIES: tuple[str, ...] = tuple(p.value for p in SelfCollisionPolicy)
"""Every spelling of ``self_collision`` (argparse ``choices``, schema ``enum``)."""
BASE_KINDS: tuple[str, ...] = tuple(b.value for b in RobotBase)
"""Every spelling of ``base`` (argparse ``choices``, schema ``enum``)."""
MESH_COLLISION_MODES: tuple[str, ...] = tuple(m.value for m in MeshCollisionMode)
"""Every spelling of ``mesh_collision`` (argparse ``choices``, schema ``enum``)."""


def _parse(cls: Any, value: object, where: str, concept: str, spellings: tuple[str, ...]) -> Any:
    try:
        return cls(value)
    except ValueError:
        raise ValueError(
            f"{where}: unknown {concept} {value!r} (one of {', '.join(spellings)})"
        ) from None


class ClockMode(_Vocabulary):
    """How simulation time moves (option ``clock``): ``lockstep`` (a client moves it with
    ``/harness/step``; the marker's and ``Session``'s default), ``fast`` (as fast as possible
    once a client connected) or ``realtime`` (paced to wall time x ``rate``; the default of
    scenario files and ``harness serve``)."""

    LOCKSTEP = "lockstep"
    FAST = "fast"
    REALTIME = "realtime"

    @classmethod
    def parse(cls, value: object, where: str = "clock") -> ClockMode:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        result: ClockMode = _parse(cls, value, where, "clock mode", CLOCK_MODES)
        return result


LIMIT_POLICY_KEY = "kinematic_limits"
"""The one name of the :class:`LimitPolicy` option: ``Session``, ``CoreOptions``,
``Simulation``, the marker, scenario controllers, ``harness serve --kinematic-limits`` and
the recording metadata."""
LIMIT_POLICY_OLD_KEY = "beyond_limits"
"""The scenario files' earlier spelling of :data:`LIMIT_POLICY_KEY`, still read (an input
alias of the scenario reader only; never written)."""


class LimitPolicy(_Vocabulary):
    """What a kinematic joint does with a command beyond its position limits (option
    ``kinematic_limits``): ``clamp`` it to the limits with a notice (the default) or ``allow``
    it (the original framework's teleporting). Dynamic joints are always clamped, as a servo's
    ``ctrlrange`` is."""

    CLAMP = "clamp"
    ALLOW = "allow"

    @classmethod
    def parse(cls, value: object, where: str = LIMIT_POLICY_KEY) -> LimitPolicy:
        """``value`` as a member; a ValueError naming ``where`` and the spellings otherwise."""
        result: LimitPolicy = _parse(cls, value, where, "limit policy", LIMIT_POLICIES)
        return result


_ACTUATION_ALIASES = {"position": "servo", DYNAMIC_ALIAS: "servo"}


class Actuation(_Vocabulary):
    """How a whole run's joints are driven when one switch overrides the declared (or
    recorded) control modes -- the "kinematic vs dynamic" switch, not a control mode (a
    :class:`ControlMode` says how one joint is driven):

    - ``kinematic``: every joint kinematic (positions written each step: teleporting);
    - ``servo``: no joint kinematic; under pytest (``--harness-actuation``) kinematic joints
      become position servos and velocity/effort joints are kept; ``harness replay
      --actuation`` re-simulates the recorded position targets with every joint a position
      servo (a mobile base: the planar base for ``kinematic``, the diff drive for ``servo``).

    ``position`` and ``dynamic`` (the values of the deprecated ``--harness-mode`` and
    ``harness replay --mode``) are input aliases of ``servo``: :meth:`parse` accepts them and
    :func:`Actuation.deprecated` tells the caller to warn."""

    KINEMATIC = "kinematic"
    SERVO = "servo"

    @classmethod
    def _missing_(cls, value: object) -> Actuation | None:
        alias = _ACTUATION_ALIASES.get(value) if isinstance(value, str) else None
        return None if alias is None else cls(alias)

    @classmethod
    def parse(cls, value: object, where: str = "actuation") -> Actuation:
        """``value`` as a member (``position``/``dynamic`` give ``SERVO``); a ValueError
        naming ``where`` and the spellings otherwise."""
        result: Actuation = _parse(cls, value, where, "actuation", ACTUATIONS)
        return result

    @staticmethod
    def deprecated(value: object) -> bool:
        """Whether ``value`` is an old spelling (``position``, ``dynamic``) of ``servo``."""
        return isinstance(value, str) and value in _ACTUATION_ALIASES


CLOCK_MODES: tuple[str, ...] = tuple(m.value for m in ClockMode)
"""Every spelling of ``clock`` (argparse ``choices``, schema ``enum``)."""
LIMIT_POLICIES: tuple[str, ...] = tuple(p.value for p in LimitPolicy)
"""Every spelling of ``kinematic_limits`` (argparse ``choices``, schema ``enum``)."""
ACTUATIONS: tuple[str, ...] = tuple(a.value for a in Actuation)
"""Every spelling of the actuation switch (``--harness-actuation``, ``replay --actuation``)."""
ACTUATION_INPUTS: tuple[str, ...] = (*ACTUATIONS, *_ACTUATION_ALIASES)
"""Every accepted spelling, the deprecated ones included (the deprecated options' choices)."""

SCHEMA_ENUMS: Mapping[str, Mapping[tuple[str, ...], tuple[str, ...]]] = {
    "scenario": {
        ("properties", "clock", "properties", "mode"): CLOCK_MODES,
        ("$defs", "robot", "properties", "self_collision"): SELF_COLLISION_POLICIES,
        ("$defs", "robot", "properties", "base"): BASE_KINDS,
        ("properties", "environment", "properties", "mesh_collision"): MESH_COLLISION_MODES,
        ("$defs", "controller", "properties", "mode"): CONTROL_MODE_INPUTS,
        ("$defs", "controller", "properties", LIMIT_POLICY_KEY): LIMIT_POLICIES,
        ("$defs", "controller", "properties", LIMIT_POLICY_OLD_KEY): LIMIT_POLICIES,
    },
}
"""Where each vocabulary's spellings sit in the shipped JSON Schemas (by schema name, then
key path to the property whose ``enum`` they are)."""


def apply_schema_enums(name: str, schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` (the shipped JSON Schema ``name``) with every vocabulary ``enum`` set from
    this module (in place, and returned); a KeyError if a listed property moved (the schema
    and :data:`SCHEMA_ENUMS` must change together)."""
    for path, spellings in SCHEMA_ENUMS.get(name, {}).items():
        node: Any = schema
        for key in path:
            node = node[key]
        node["enum"] = list(spellings)
    return schema
