"""A world's keyframes: each robot's keys combined with the scene's into one key per name,
with ``initial_positions`` applied to ``home`` (see :func:`harness.models.load_world`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.build.robot import RobotBuild, dof_span, qpos_span
from harness.models.errors import ModelStructureError

__all__ = ["combine_keyframes"]


def combine_keyframes(
    spec: mujoco.MjSpec, first: mujoco.MjModel, robots: Sequence[RobotBuild], several: bool
) -> None:
    """Replace the robots' own keys (and the scene's keys of the same names) with combined
    keys (see :func:`load_world`)."""
    names: list[str] = []
    for robot in robots:
        for name in (*robot.extension_keys, *robot.spec_keys):
            if name not in names:
                names.append(name)
    if "home" not in names and any(r.request.initial_positions for r in robots):
        names.append("home")
    if not names:
        return
    robot_keys = {r.prefix + k for r in robots for k in r.spec_keys}
    scene_keys = {
        first.key(k).name: k for k in range(first.nkey) if first.key(k).name not in robot_keys
    }
    added_actuators = [
        (robot, joint)
        for robot in robots
        if not robot.existing_actuators
        for joint in robot.actuated
    ]
    keys: list[dict[str, Any]] = []
    for name in names:
        scene_key = scene_keys.get(name, -1)
        qpos = np.array(first.qpos0 if scene_key < 0 else first.key_qpos[scene_key], dtype=float)
        qvel = np.zeros(first.nv) if scene_key < 0 else np.array(first.key_qvel[scene_key])
        ctrl = np.zeros(first.nu) if scene_key < 0 else np.array(first.key_ctrl[scene_key])
        act = np.zeros(first.na) if scene_key < 0 else np.array(first.key_act[scene_key])
        time = 0.0 if scene_key < 0 else float(first.key_time[scene_key])
        for robot in robots:
            own, _ = robot.key_values(first, name, qpos)
            joints = robot.joint_ids(first)
            if own >= 0:
                time = float(first.key_time[own])
                for j in joints:
                    start, width = dof_span(first, j)
                    qvel[start : start + width] = first.key_qvel[own][start : start + width]
            if name == "home":
                _apply_initial_positions(first, robot, qpos, several)
            for a in range(first.nu):
                joint = int(first.actuator_trnid[a][0])
                if first.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT or joint not in joints:
                    continue
                if own >= 0:
                    ctrl[a] = first.key_ctrl[own][a]
                unprefixed = first.joint(joint).name.removeprefix(robot.prefix)
                overridden = name == "home" and unprefixed in robot.request.initial_positions
                if overridden and robot.modes.get(unprefixed) == "position":
                    ctrl[a] = qpos[first.jnt_qposadr[joint]]
        added = [
            float(qpos[first.jnt_qposadr[first.joint(robot.prefix + joint).id]])
            if robot.modes.get(joint) == "position"
            else 0.0
            for robot, joint in added_actuators
        ]
        # each added position servo's command filter starts at its command
        filtered = [
            value
            for value, (robot, joint) in zip(added, added_actuators, strict=True)
            if robot.modes.get(joint) == "position"
        ]
        keys.append(
            {
                "name": name,
                "time": time,
                "qpos": qpos.tolist(),
                "qvel": qvel.tolist(),
                "ctrl": [*ctrl.tolist(), *added],
                "act": [*act.tolist(), *filtered],
            }
        )
    for key in list(spec.keys):
        if key.name in robot_keys or key.name in names:
            spec.delete(key)
    for key_options in keys:
        spec.add_key(**key_options)


def _apply_initial_positions(
    model: mujoco.MjModel, robot: RobotBuild, qpos: npt.NDArray[np.float64], several: bool
) -> None:
    wanted = robot.request.initial_positions
    single_dof = {
        model.joint(j).name.removeprefix(robot.prefix): j
        for j in robot.joint_ids(model)
        if qpos_span(model, j)[1] == 1
    }
    unknown = sorted(set(wanted) - set(single_dof))
    if unknown:
        raise ModelStructureError(
            f"{robot.where(several)}: initial_positions name no hinge or slide joint of the "
            f"robot: {unknown} (joints: {', '.join(sorted(single_dof))})"
        )
    for name, value in wanted.items():
        if not math.isfinite(value):
            raise ModelStructureError(
                f"{robot.where(several)}: initial_positions[{name!r}] = {value!r} is not finite"
            )
        qpos[model.jnt_qposadr[single_dof[name]]] = value
