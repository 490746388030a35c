"""Fixtures of the simulation tests: a small MJCF arm built with actuators per control mode
(as harness.models does for URDFs) and the demo robot."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import NamedTuple

import mujoco
import pytest

ARM_XML = Path(__file__).resolve().parents[1] / "data" / "sim" / "arm.xml"
ARM_JOINTS = ("j1", "j2", "j3", "finger_left_joint")


def build_arm(
    control: str | Mapping[str, str] = "position",
    *,
    kp: float = 300.0,
    kv: float = 20.0,
    timestep: float | None = None,
    sleep: bool = False,
    force_limits: bool = True,
) -> mujoco.MjModel:
    """The test arm with one actuator per non-kinematic joint of the given mode."""
    spec = mujoco.MjSpec.from_file(str(ARM_XML))
    if not force_limits:
        for joint in spec.joints:
            joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    if timestep is not None:
        spec.option.timestep = timestep
    if sleep:
        spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    modes = {j: control for j in ARM_JOINTS} if isinstance(control, str) else dict(control)
    for joint, mode in modes.items():
        if mode == "kinematic":
            continue
        act = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if mode == "position":
            act.set_to_position(kp=kp, dampratio=1.0)
        elif mode == "velocity":
            act.set_to_velocity(kv=kv)
        else:
            act.set_to_motor()
    return spec.compile()


def arm_targets(step: int, dt: float = 0.002) -> dict[str, float]:
    """A sweep of the test arm: down beside the box (0.6 s), then through it along +y."""
    t = step * dt
    if t < 0.6:
        s = t / 0.6
        return {"j1": -0.5 * s, "j2": 0.35 * s, "j3": 0.2 * s, "finger_left_joint": 0.02 * s}
    s = min((t - 0.6) / 1.4, 1.0)
    return {"j1": -0.5 + 1.0 * s, "j2": 0.35, "j3": 0.2, "finger_left_joint": 0.02}


class ArmKit(NamedTuple):
    build: Callable[..., mujoco.MjModel]
    targets: Callable[[int], dict[str, float]]
    joints: tuple[str, ...]


@pytest.fixture
def arm() -> ArmKit:
    """The test arm's builder, sweep targets and controllable joints."""
    return ArmKit(build_arm, arm_targets, ARM_JOINTS)
