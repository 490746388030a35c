"""The files the harness ships: the demo robot and the named scenes."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

__all__ = ["DATA", "DEMO_URDF", "SCENES"]

DATA = Path(__file__).resolve().parent / "data"
DEMO_URDF = DATA / "demo_arm.urdf"
"""The bundled demo robot (Panda kinematics and limits, two-finger gripper). Its ``home``
keyframe and joint armature are in the file (``<harness>``), so any copy loads the same."""
SCENES: Mapping[str, Path] = MappingProxyType(
    {name: DATA / "scenes" / f"{name}.xml" for name in ("floor", "empty", "table")}
)
"""Named scenes: ``floor`` (what ``scene=None`` gives a URDF/SDF robot), ``empty`` (floor and
light), ``table`` (floor, light, a table and a free box within the demo arm's reach)."""
