"""A :class:`RobotModel` from a compiled MuJoCo model (MJCF sources, loaded as is)."""

from __future__ import annotations

import mujoco
import numpy as np

from harness.models.description import (
    Geometry,
    Inertial,
    Joint,
    JointLimits,
    JointType,
    Link,
    Mimic,
    Pose,
    RobotModel,
    Shape,
)

__all__ = ["description_from_model"]


def _pose(pos: np.typing.ArrayLike, quat: np.typing.ArrayLike) -> Pose:
    p = np.asarray(pos, dtype=float)
    q = np.asarray(quat, dtype=float)
    return Pose(
        (float(p[0]), float(p[1]), float(p[2])),
        (float(q[0]), float(q[1]), float(q[2]), float(q[3])),
    ).normalized()


def _geometry(model: mujoco.MjModel, g: int) -> Geometry | None:
    size = [float(s) for s in model.geom_size[g]]
    kind = int(model.geom_type[g])
    gt = mujoco.mjtGeom
    if kind == gt.mjGEOM_BOX:
        return Geometry("box", (2 * size[0], 2 * size[1], 2 * size[2]))
    if kind == gt.mjGEOM_CYLINDER:
        return Geometry("cylinder", (size[0], 2 * size[1]))
    if kind == gt.mjGEOM_CAPSULE:
        return Geometry("capsule", (size[0], 2 * size[1]))
    if kind == gt.mjGEOM_SPHERE:
        return Geometry("sphere", (size[0],))
    if kind == gt.mjGEOM_ELLIPSOID:
        return Geometry("ellipsoid", (size[0], size[1], size[2]))
    if kind == gt.mjGEOM_PLANE:
        return Geometry("plane", (2 * size[0], 2 * size[1]))
    if kind == gt.mjGEOM_MESH:
        return Geometry("mesh", (), model.mesh(int(model.geom_dataid[g])).name or None)
    return None


def description_from_model(model: mujoco.MjModel, name: str, source: str | None) -> RobotModel:
    """Bodies as links and joints as joints, posed at ``qpos0`` (the model's zero configuration);
    a body without a joint is fixed to its parent body (``<parent>_to_<child>``), except under
    the world, where it stays a root link.

    Joint equality constraints ``joint1 = f(joint2)`` become mimics of ``joint2``.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)

    def body_name(b: int) -> str:
        return model.body(b).name or f"body{b}"

    links = []
    for b in range(1, model.nbody):
        pose = _pose(data.xpos[b], data.xquat[b])
        inertial = None
        if model.body_mass[b] > 0:
            ipose = Pose.from_matrix(_matrix(data.xipos[b], data.ximat[b]))
            ix, iy, iz = (float(v) for v in model.body_inertia[b])
            inertial = Inertial(float(model.body_mass[b]), ipose, (ix, 0.0, 0.0, iy, 0.0, iz))
        collisions: list[Shape] = []
        visuals: list[Shape] = []
        for g in range(model.ngeom):
            if model.geom_bodyid[g] != b:
                continue
            geometry = _geometry(model, g)
            if geometry is None:
                continue
            gpose = Pose.from_matrix(_matrix(data.geom_xpos[g], data.geom_xmat[g]))
            shape = Shape(model.geom(g).name or f"geom{g}", gpose, geometry)
            colliding = model.geom_contype[g] or model.geom_conaffinity[g]
            (collisions if colliding else visuals).append(shape)
        links.append(Link(body_name(b), pose, inertial, tuple(collisions), tuple(visuals)))

    mimics: dict[int, Mimic] = {}
    for e in range(model.neq):
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[e] >= 0:
            leader = model.joint(int(model.eq_obj2id[e])).name
            coef = model.eq_data[e]
            mimics[int(model.eq_obj1id[e])] = Mimic(leader, float(coef[1]), float(coef[0]))

    joints = []
    for j in range(model.njnt):
        b = int(model.jnt_bodyid[j])
        jt = int(model.jnt_type[j])
        limited = bool(model.jnt_limited[j])
        types: dict[int, JointType] = {
            mujoco.mjtJoint.mjJNT_FREE: "floating",
            mujoco.mjtJoint.mjJNT_BALL: "ball",
            mujoco.mjtJoint.mjJNT_SLIDE: "prismatic",
            mujoco.mjtJoint.mjJNT_HINGE: "revolute" if limited else "continuous",
        }
        lower = upper = effort = None
        if limited and jt in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            lower, upper = (float(v) for v in model.jnt_range[j])
        if model.jnt_actfrclimited[j]:
            effort = float(max(abs(v) for v in model.jnt_actfrcrange[j]))
        axis = (0.0, 0.0, 0.0)
        if jt in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            axis = (float(data.xaxis[j][0]), float(data.xaxis[j][1]), float(data.xaxis[j][2]))
        pos = data.xanchor[j]
        pose = Pose(
            (float(pos[0]), float(pos[1]), float(pos[2])), _pose(data.xpos[b], data.xquat[b]).quat
        )
        dof = int(model.jnt_dofadr[j])
        joints.append(
            Joint(
                model.joint(j).name or f"joint{j}",
                types[jt],
                body_name(int(model.body_parentid[b])) if model.body_parentid[b] else "world",
                body_name(b),
                pose,
                axis,
                JointLimits(lower, upper, None, effort),
                mimics.get(j),
                float(model.dof_damping[dof]),
                float(model.dof_frictionloss[dof]),
            )
        )
    # A body without a joint is welded to its parent body: a fixed joint, as URDF says it (the
    # link then hangs from its parent in /tf_static and /robot_description, not from the world).
    taken = {j.name for j in joints}
    for b in range(1, model.nbody):
        parent = int(model.body_parentid[b])
        if model.body_jntnum[b] or not parent:
            continue
        joint_name = f"{body_name(parent)}_to_{body_name(b)}"
        while joint_name in taken:
            joint_name += "_fixed"
        taken.add(joint_name)
        joints.append(
            Joint(
                joint_name,
                "fixed",
                body_name(parent),
                body_name(b),
                _pose(data.xpos[b], data.xquat[b]),
            )
        )
    return RobotModel(name, tuple(links), tuple(joints), (), source, "mjcf")


def _matrix(pos: np.typing.ArrayLike, mat: np.typing.ArrayLike) -> np.typing.NDArray[np.float64]:
    m = np.eye(4)
    m[:3, :3] = np.asarray(mat, dtype=float).reshape(3, 3)
    m[:3, 3] = np.asarray(pos, dtype=float)
    return m
