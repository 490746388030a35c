"""Contact surfaces as Gazebo users write them in a URDF: ``<gazebo reference="link">`` with
``<mu1>``/``<mu2>`` (ODE's friction coefficients along two directions).

MuJoCo has one sliding coefficient per geom and, for a pair, takes the larger one unless a geom
has a higher ``priority``. So a link with declared friction gets the smaller of ``mu1``/``mu2``
(isotropic) on each of its collision geoms, with priority 1: its own value decides its contacts,
and a zero-friction caster slides on any floor, as in Gazebo (its contacts are frictionless,
``condim`` 1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import mujoco
from lxml import etree

from harness.models.errors import ModelStructureError

__all__ = ["MAX_FRICTION", "SURFACE_PRIORITY", "apply_frictions", "gazebo_frictions"]

SURFACE_PRIORITY = 1
"""The MuJoCo geom priority of a surface whose friction the file declares."""
MAX_FRICTION = 2.0
"""Larger coefficients are taken as this: Gazebo files write 1e14 for "never slips", which
MuJoCo's solver cannot digest (rubber on concrete is about 1; at 2 a wheel does not slip under
any load a robot's drive can put on it, and a stiff, very high coefficient makes MuJoCo's soft
contacts push on the joints above it)."""


def gazebo_frictions(root: etree._Element, source: str) -> dict[str, float]:
    """Link name -> sliding friction from the URDF's ``<gazebo reference>`` ``mu1``/``mu2``."""
    found: dict[str, float] = {}
    for gazebo in root.findall("gazebo"):
        link = gazebo.get("reference")
        if not link:
            continue
        values = []
        for tag in ("mu1", "mu2"):
            element = gazebo.find(tag)
            if element is None:
                continue
            text = element.get("value") if element.get("value") is not None else element.text
            try:  # <mu1>0.5</mu1>, or <mu1 value="0.5"/> as Gazebo Classic also reads it
                value = float((text or "").strip())
            except ValueError:
                value = math.nan
            if not (math.isfinite(value) and value >= 0):
                raise ModelStructureError(
                    f"{source}: line {element.sourceline}: <gazebo reference={link!r}> <{tag}> "
                    f"{text!r} is not a friction coefficient >= 0"
                )
            values.append(value)
        if values:
            found[link] = min(*values, MAX_FRICTION)
    return found


def apply_frictions(spec: mujoco.MjSpec, frictions: Mapping[str, float], source: str) -> None:
    """Give the collision geoms of each link in ``frictions`` its sliding friction (see the
    module docstring); a link that is not a body of ``spec`` is an error naming it."""
    for link, mu in frictions.items():
        body = spec.body(link)
        if body is None:
            raise ModelStructureError(
                f"{source}: <gazebo reference={link!r}> names no link of the robot"
            )
        for geom in body.geoms:
            if geom.contype == 0 and geom.conaffinity == 0:
                continue  # a visual
            geom.friction = [mu, geom.friction[1], geom.friction[2]]
            geom.priority = SURFACE_PRIORITY
            if mu == 0.0:
                geom.condim = 1  # frictionless: a zero-width friction pyramid is degenerate
