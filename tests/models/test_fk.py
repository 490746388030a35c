"""Forward kinematics: MuJoCo (through our loader) and the RobotModel agree with yourdfpy."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yourdfpy

from harness.models import DEMO_URDF, Pose, load_description, load_robot

CONFIGS = 100


def _cases(robots: Path, data: Path) -> dict[str, Path]:
    return {
        "demo": DEMO_URDF,
        "panda": robots / "panda_description/urdf/panda.urdf",
        "ur5": robots / "ur_description/urdf/ur5_robot.urdf",
        "rotated_chain": data / "rotated_chain.urdf",
    }


def _oracle(path: Path) -> yourdfpy.URDF:
    return yourdfpy.URDF.load(
        str(path), load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False
    )


def _pose_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)))


@pytest.mark.parametrize("name", ["demo", "panda", "ur5", "rotated_chain"])
def test_mujoco_body_poses_match_yourdfpy(name, robots, data_dir, mesh_cache):
    path = _cases(robots, data_dir)[name]
    # link meshes as hulls: body poses do not depend on them (the UR5's two concave ones
    # would be decomposed cold here)
    loaded = load_robot(path, scene="empty", cache_dir=mesh_cache, mesh_collision="hull")
    model, data = loaded.model, mujoco.MjData(loaded.model)
    urdf = _oracle(path)
    description = loaded.description
    leaders = [j for j in description.joints if j.is_controllable]
    followers = [j for j in description.joints if j.mimic is not None]
    assert {j.name for j in leaders} == set(urdf.actuated_joint_names)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(CONFIGS):
        cfg: dict[str, float] = {}
        for joint in leaders:
            lo = joint.limits.lower if joint.limits.lower is not None else -math.pi
            hi = joint.limits.upper if joint.limits.upper is not None else math.pi
            if joint.type == "continuous":
                lo, hi = -math.pi, math.pi
            cfg[joint.name] = float(rng.uniform(lo, hi))
        for joint in followers:
            assert joint.mimic is not None
            cfg[joint.name] = joint.mimic.multiplier * cfg[joint.mimic.joint] + joint.mimic.offset
        urdf.update_cfg({n: cfg[n] for n in urdf.actuated_joint_names})
        for joint_name, value in cfg.items():
            data.qpos[model.jnt_qposadr[model.joint(joint_name).id]] = value
        mujoco.mj_kinematics(model, data)
        base = urdf.base_link
        for link in description.links:
            if link.name == "world":
                continue
            # the robot may have been lifted out of the floor: its model frame is `placement`
            expected = loaded.placement.matrix() @ urdf.get_transform(
                frame_to=link.name, frame_from=base
            )
            body = model.body(link.name).id
            actual = np.eye(4)
            actual[:3, :3] = data.xmat[body].reshape(3, 3)
            actual[:3, 3] = data.xpos[body]
            worst = max(worst, _pose_error(actual, expected))
    assert worst < 1e-9, f"{name}: max |T_mujoco - T_yourdfpy| = {worst:.3g}"


@pytest.mark.parametrize("name", ["demo", "panda", "ur5", "rotated_chain"])
def test_description_zero_configuration_matches_yourdfpy(name, robots, data_dir):
    path = _cases(robots, data_dir)[name]
    description = load_description(path)
    urdf = _oracle(path)
    urdf.update_cfg(np.zeros(len(urdf.actuated_joint_names)))
    for link in description.links:
        expected = Pose.from_matrix(
            urdf.get_transform(frame_to=link.name, frame_from=urdf.base_link)
        )
        assert link.pose.is_close(expected, atol=1e-12), link.name
    for joint in description.joints:
        child = Pose.from_matrix(
            urdf.get_transform(frame_to=joint.child, frame_from=urdf.base_link)
        )
        assert joint.pose.is_close(child, atol=1e-12), joint.name
        oracle_joint = urdf.joint_map[joint.name]
        if joint.type in ("revolute", "continuous", "prismatic"):
            axis = np.asarray(oracle_joint.axis, dtype=float)
            expected_axis = child.rotate(axis / np.linalg.norm(axis))
            assert np.allclose(joint.axis, expected_axis, atol=1e-12), joint.name
        if oracle_joint.limit is not None:
            assert joint.limits.velocity == oracle_joint.limit.velocity
            assert joint.limits.effort == oracle_joint.limit.effort
