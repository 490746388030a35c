"""build_spec: every corpus model compiles, bodies sit where the RobotModel says, loops close."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from harness.models.description import Pose, RobotModel
from harness.models.sdf import FREE_JOINT_SUFFIX, SdfWarning, build_spec, read_sdf, read_sdf_world
from harness.models.sdf.build import spanning_tree

DATA = Path(__file__).parent.parent / "data" / "sdf"


def _corpus_models() -> list[Any]:
    cases = []
    for path in sorted(DATA.glob("*.sdf")) + sorted((DATA / "harness").glob("*.sdf")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SdfWarning)
            world = read_sdf_world(path)
        for placed in world.models:
            if placed.model.links:
                cases.append(pytest.param(placed.model, id=f"{path.name}:{placed.name}"))
    return cases


def _compile(model: RobotModel) -> mujoco.MjModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SdfWarning)
        return build_spec(model).compile()


# joint_complete.sdf's revolute2 joint has both axes along z (a degenerate file upstream)
_DEGENERATE = "ignore:Inertia matrix is too close to singular"


@pytest.mark.filterwarnings(_DEGENERATE)
@pytest.mark.parametrize("model", _corpus_models())
def test_compiles_with_bodies_at_model_poses(model: RobotModel) -> None:
    compiled = _compile(model)
    data = mujoco.MjData(compiled)
    mujoco.mj_kinematics(compiled, data)
    for link in model.links:
        body = compiled.body(link.name)
        got = Pose(tuple(data.xpos[body.id]), tuple(data.xquat[body.id]))  # type: ignore[arg-type]
        assert got.is_close(link.pose, atol=1e-9), link.name
    loops = {j.name for j in spanning_tree(model).loops}
    for joint in model.joints:
        if joint.type in ("revolute", "continuous", "prismatic") and joint.name not in loops:
            jnt = compiled.joint(joint.name)
            assert np.allclose(data.xaxis[jnt.id], joint.axis, atol=1e-9), joint.name
            assert np.allclose(data.xanchor[jnt.id], joint.pose.xyz, atol=1e-9), joint.name


@pytest.mark.filterwarnings(_DEGENERATE)
def test_joint_complete_maps_every_type() -> None:
    with pytest.warns(SdfWarning, match="gearbox_joint.*no MuJoCo equivalent"):
        model = read_sdf(DATA / "joint_complete.sdf")
    types = {j.name: j.type for j in model.joints}
    assert types["ball_joint"] == "ball"
    assert types["continuous_joint"] == "continuous"
    assert types["universal_joint"] == types["universal_joint::axis2"] == "revolute"
    assert types["revolute2_joint::axis2"] == "revolute"
    assert "gearbox_joint" not in types
    revolute = model.joint("revolute_joint")
    assert (revolute.limits.lower, revolute.limits.upper) == (-0.5, 0.5)
    assert (revolute.limits.effort, revolute.limits.velocity) == (123.4, 12.0)
    assert (revolute.damping, revolute.friction) == (0.1, 0.2)
    with pytest.warns(SdfWarning, match="screw_joint"):
        compiled = build_spec(model).compile()
    universal = compiled.joint("universal_joint")
    assert compiled.joint("universal_joint::axis2").bodyid == universal.bodyid
    assert compiled.jnt_type[compiled.joint("ball_joint").id] == mujoco.mjtJoint.mjJNT_BALL


def test_free_joints_follow_gazebo_semantics() -> None:
    model = read_sdf(DATA / "model_link_relative_to.sdf")
    free = [j for j in model.joints if j.type == "floating"]
    assert [j.child for j in free] == ["L1", "L2", "L2a", "L3"]
    assert all(j.name == j.child + FREE_JOINT_SUFFIX and j.parent == "world" for j in free)
    fixed = read_sdf(DATA / "harness" / "arm.sdf")
    assert not [j for j in fixed.joints if j.type == "floating"]


def test_loops_become_equalities_that_hold() -> None:
    model = read_sdf(DATA / "harness" / "loops.sdf")
    spec = build_spec(model)
    compiled = spec.compile()
    kinds = {compiled.eq(i).name: int(compiled.eq_type[i]) for i in range(compiled.neq)}
    assert kinds["close_loop"] == kinds["close_loop::axis_point"] == mujoco.mjtEq.mjEQ_CONNECT
    assert kinds["mimic:follow"] == mujoco.mjtEq.mjEQ_JOINT
    assert compiled.jnt_type[compiled.joint("ball").id] == mujoco.mjtJoint.mjJNT_BALL
    assert compiled.body("weld_plate").parentid == compiled.body("pendulum").id
    data = mujoco.MjData(compiled)
    mujoco.mj_forward(compiled, data)
    connect_rows = [r for r in range(data.ne) if data.efc_id[r] != compiled.eq("mimic:follow").id]
    assert np.allclose(data.efc_pos[connect_rows], 0.0, atol=1e-12)
    # the mimic relation q_follow = 2 q_crank + 0.1 is what the equality enforces
    eq = compiled.eq("mimic:follow")
    assert np.allclose(compiled.eq_data[eq.id][:2], [0.1, 2.0])
    # driven by gravity for a while, the closed four-bar stays closed
    compiled.opt.gravity = (3.0, 0.0, -9.81)
    for _ in range(500):
        mujoco.mj_step(compiled, data)
    coupler_tip = data.xpos[compiled.body("coupler").id] + data.xmat[
        compiled.body("coupler").id
    ].reshape(3, 3) @ np.array([1.0, 0.0, 0.0])
    rocker_top = data.xpos[compiled.body("rocker").id] + data.xmat[
        compiled.body("rocker").id
    ].reshape(3, 3) @ np.array([0.0, 0.0, 1.0])
    assert abs(data.qpos[compiled.joint("crank_joint").qposadr[0]]) > 1e-3
    assert np.allclose(coupler_tip, rocker_top, atol=1e-3)
