"""The drive model of a controlled joint: what a real position- or velocity-controlled joint
does beyond the servo law itself.

Industrial and research arms hold their pose under gravity because their drive controllers
add the gravity torque of the links they carry (computed from the robot's model) to the
servo's output; the servo only corrects the residual. The harness does the same with
MuJoCo's gravity compensation: every link carried only by position- or velocity-controlled
(or kinematic) joints gets ``gravcomp = 1``, and those joints take the compensation as
actuator force (``actuatorgravcomp``), so it counts against the joint's effort limit like any
other torque of the drive: a joint too weak for its load still sags.

Links carried by a passive joint (a free-floating base, a ball joint) or an effort-controlled
joint are not compensated: nothing in a real robot would apply that force. A mimic follower is
driven by its leader's drive (a linkage or tendon): it counts with its leader's mode.
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco

from harness.models.description import ControlMode

__all__ = ["COMMAND_FILTER_SECONDS", "COMPENSATED_MODES", "compensated_bodies"]

COMMAND_FILTER_SECONDS = 0.02
"""Time constant of the first-order filter a position drive puts on its command (as real
drives interpolate setpoints that arrive as a staircase): a command sent every few steps is
followed smoothly instead of as a train of velocity pulses. The filter state is MuJoCo
actuator activation, part of the recorded physics state."""

COMPENSATED_MODES: tuple[ControlMode, ...] = (
    ControlMode.POSITION,
    ControlMode.VELOCITY,
    ControlMode.KINEMATIC,
)
"""Control modes whose drive compensates gravity."""
_HINGE_OR_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def compensated_bodies(
    model: mujoco.MjModel, bodies: Mapping[str, int], modes: Mapping[int, ControlMode]
) -> list[str]:
    """The links (of ``bodies``: link name -> body id) that get gravity compensation:
    every joint between the link and the world is a hinge or slide whose mode (``modes``:
    joint id -> mode) is one of :data:`COMPENSATED_MODES`, and at least one joint carries it.
    """
    chosen = []
    for name, body in bodies.items():
        carried, ok = False, True
        current = body
        while current != 0 and ok:
            start = int(model.body_jntadr[current])
            for joint in range(start, start + int(model.body_jntnum[current])):
                kind = int(model.jnt_type[joint])
                hinge_or_slide = kind in _HINGE_OR_SLIDE
                if not hinge_or_slide or modes.get(joint) not in COMPENSATED_MODES:
                    ok = False
                    break
                carried = True
            current = int(model.body_parentid[current])
        if ok and carried:
            chosen.append(name)
    return chosen
