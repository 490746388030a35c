"""The same robot written as SDF and as URDF has the same forward kinematics."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yourdfpy

from harness.models import load_robot
from harness.models.sdf import build_spec, read_sdf

DATA = Path(__file__).parent.parent / "data" / "sdf" / "harness"
LINKS = ("base", "l1", "l2", "l3", "l4", "tool")
JOINTS = ("j1", "j2", "j3", "j4")


def _configurations(count: int) -> np.ndarray:
    rng = np.random.default_rng(1234)
    lower = np.array([-2.5, -1.5, -0.1, -np.pi])
    upper = np.array([2.5, 1.5, 0.1, np.pi])
    return np.asarray(rng.uniform(lower, upper, size=(count, len(JOINTS))))


def _mujoco_poses(model: mujoco.MjModel, q: np.ndarray) -> dict[str, np.ndarray]:
    data = mujoco.MjData(model)
    for name, value in zip(JOINTS, q, strict=True):
        data.qpos[model.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(model, data)
    poses = {}
    for link in LINKS:
        body = model.body(link).id
        matrix = np.eye(4)
        matrix[:3, :3] = data.xmat[body].reshape(3, 3)
        matrix[:3, 3] = data.xpos[body]
        poses[link] = matrix
    return poses


def test_sdf_description_matches_urdf() -> None:
    sdf = read_sdf(DATA / "arm.sdf")
    urdf = yourdfpy.URDF.load(str(DATA / "arm.urdf"), load_meshes=False)
    for joint in JOINTS:
        sdf_joint = sdf.joint(joint)
        urdf_axis = urdf.get_transform(urdf.joint_map[joint].child, "base")[:3, :3] @ (
            urdf.joint_map[joint].axis / np.linalg.norm(urdf.joint_map[joint].axis)
        )
        assert np.allclose(sdf_joint.axis, urdf_axis, atol=1e-12), joint
    assert sdf.joint("j4").type == "continuous"
    assert (sdf.joint("j3").limits.lower, sdf.joint("j3").limits.upper) == (-0.1, 0.1)
    assert sdf.frames[0].name == "tcp"
    assert sdf.frames[0].attached_to == "tool"


def test_forward_kinematics_match_yourdfpy() -> None:
    compiled = build_spec(read_sdf(DATA / "arm.sdf")).compile()
    urdf = yourdfpy.URDF.load(str(DATA / "arm.urdf"), load_meshes=False)
    assert tuple(urdf.actuated_joint_names) == JOINTS
    for q in _configurations(25):
        urdf.update_cfg(q)
        ours = _mujoco_poses(compiled, q)
        for link in LINKS:
            theirs = urdf.get_transform(link, "base")
            assert np.allclose(ours[link], theirs, atol=1e-9), (link, q)


def test_forward_kinematics_match_the_urdf_load_path() -> None:
    from_sdf = load_robot(DATA / "arm.sdf")
    from_urdf = load_robot(DATA / "arm.urdf")
    assert from_sdf.actuated == from_urdf.actuated == JOINTS
    for q in _configurations(10):
        ours = _mujoco_poses(from_sdf.model, q)
        theirs = _mujoco_poses(from_urdf.model, q)
        for link in LINKS:
            assert np.allclose(ours[link], theirs[link], atol=1e-9), (link, q)
    for link in LINKS:
        a, b = from_sdf.model.body(link), from_urdf.model.body(link)
        assert a.mass[0] == pytest.approx(b.mass[0], abs=1e-12), link
        assert np.allclose(a.inertia, b.inertia, atol=1e-12), link
        assert np.allclose(a.ipos, b.ipos, atol=1e-12), link
