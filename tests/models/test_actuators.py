"""One actuator per controllable joint, of the requested kind, with ranges from the limits."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.errors import ModelError
from harness.models import load_robot

AFFINE = mujoco.mjtBias.mjBIAS_AFFINE
NONE = mujoco.mjtBias.mjBIAS_NONE


def test_modes_ranges_and_mimic():
    control = {"joint1": "kinematic", "joint2": "velocity", "joint3": "effort"}
    loaded = load_robot("demo", control=control)
    m = loaded.model
    assert loaded.kinematic == ("joint1",)
    assert loaded.actuated == (
        "joint2",
        "joint3",
        "joint4",
        "joint5",
        "joint6",
        "joint7",
        "finger_joint1",
    )
    assert m.nu == len(loaded.actuated)
    assert dict(loaded.control) == {
        "joint1": "kinematic",
        "joint2": "velocity",
        "joint3": "effort",
        "joint4": "position",
        "joint5": "position",
        "joint6": "position",
        "joint7": "position",
        "finger_joint1": "position",
    }
    names = [m.actuator(i).name for i in range(m.nu)]
    assert names == list(loaded.actuated)
    for i, joint in enumerate(loaded.actuated):
        assert m.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
        assert m.joint(int(m.actuator_trnid[i][0])).name == joint
    limits = {j.name: j.limits for j in loaded.description.joints}

    vel = m.actuator("joint2").id
    assert m.actuator_biastype[vel] == AFFINE
    assert m.actuator_biasprm[vel][1] == 0
    assert m.actuator_biasprm[vel][2] < 0
    assert np.allclose(m.actuator_ctrlrange[vel], [-2.175, 2.175])
    assert np.allclose(m.actuator_forcerange[vel], [-87, 87])

    # only position servos get the drive's speed limit as joint damping
    for joint in ("joint1", "joint2", "joint3"):
        assert m.dof_damping[m.jnt_dofadr[m.joint(joint).id]] == 0.0

    eff = m.actuator("joint3").id
    assert m.actuator_biastype[eff] == NONE
    assert m.actuator_gainprm[eff][0] == 1
    assert np.allclose(m.actuator_ctrlrange[eff], [-87, 87])

    for joint in ("joint4", "joint5", "joint6", "joint7", "finger_joint1"):
        a = m.actuator(joint).id
        kp = m.actuator_gainprm[a][0]
        assert m.actuator_biastype[a] == AFFINE
        assert m.actuator_biasprm[a][1] == -kp
        assert m.actuator_biasprm[a][2] <= 0
        lim = limits[joint]
        assert np.allclose(m.actuator_ctrlrange[a], [lim.lower, lim.upper])
        assert np.allclose(m.actuator_forcerange[a], [-lim.effort, lim.effort])
        assert m.actuator_ctrllimited[a]
        assert m.actuator_forcelimited[a]


def test_position_servos_are_critically_damped_with_the_drive_speed_limit_as_damping():
    loaded = load_robot("demo")
    m = loaded.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    for joint in loaded.actuated:
        a = m.actuator(joint).id
        dof = m.jnt_dofadr[m.joint(joint).id]
        spec = loaded.description.joint(joint)
        lim = spec.limits
        # the drive's torque-speed line: full effort at standstill, none at the velocity limit
        assert m.dof_damping[dof] == pytest.approx(spec.damping + lim.effort / lim.velocity)
        kp, kv = m.actuator_gainprm[a][0], -m.actuator_biasprm[a][2]
        # servo and joint damping together: critically damped for the inertia the joint sees
        # with the others held (mass matrix diagonal at home, armature included), unless the
        # drive's damping alone is more (the slow fingers)
        critical = 2 * np.sqrt(kp * full[dof, dof])
        assert kv + m.dof_damping[dof] == pytest.approx(max(critical, m.dof_damping[dof]))
        # stable: sqrt(kp / M) * dt <= 0.5 for the smallest effective inertia
        assert np.sqrt(kp * m.dof_invweight0[dof]) * m.opt.timestep <= 0.5 + 1e-12
    arm = [m.dof_armature[m.jnt_dofadr[m.joint(f"joint{i}").id]] for i in range(1, 8)]
    assert arm == [0.1] * 7


def test_gains_override():
    default = load_robot("demo").model
    tuned = load_robot("demo", gains={"joint1": 1234.0}).model
    assert tuned.actuator_gainprm[tuned.actuator("joint1").id][0] == 1234.0
    assert default.actuator_gainprm[default.actuator("joint1").id][0] != 1234.0


def test_default_gains_hold_home_stably():
    loaded = load_robot("demo")
    m = loaded.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    for _ in range(1000):
        mujoco.mj_step(m, d)
    assert sum(w.number for w in d.warning) == 0
    for joint in loaded.actuated:
        target = d.ctrl[m.actuator(joint).id]
        q = d.qpos[m.jnt_qposadr[m.joint(joint).id]]
        assert abs(q - target) < 0.02, joint


def test_one_mode_for_all_and_kinematic_everything():
    loaded = load_robot("demo", control="kinematic")
    assert loaded.model.nu == 0
    assert loaded.actuated == ()
    assert set(loaded.kinematic) == {f"joint{i}" for i in range(1, 8)} | {"finger_joint1"}


def test_unknown_joint_and_mode_are_errors():
    with pytest.raises(ModelError, match=r"not controllable joints.*'nope'"):
        load_robot("demo", control={"nope": "position"})
    with pytest.raises(ModelError, match=r"not controllable joints.*'finger_joint2'"):
        load_robot("demo", control={"finger_joint2": "position"})
    with pytest.raises(ModelError, match=r"unknown control mode 'torque'"):
        load_robot("demo", control="torque")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match=r"gains name joints.*'hand_joint'"):
        load_robot("demo", gains={"hand_joint": 10.0})


def test_srdf_disable_collisions_become_excludes(data_dir, robots, mesh_cache):
    base = load_robot("demo").model
    loaded = load_robot("demo", srdf=data_dir / "demo_arm.srdf")
    m = loaded.model
    assert m.nexclude == base.nexclude + 2
    pairs = {frozenset((int(s) >> 16, int(s) & 0xFFFF)) for s in m.exclude_signature}
    for a, b in (("link0", "link2"), ("link5", "link7")):
        assert frozenset((m.body(a).id, m.body(b).id)) in pairs
    assert "srdf/demo_arm.srdf" in loaded.sources
    panda = load_robot(
        robots / "panda_description/urdf/panda.urdf",
        srdf=robots / "panda_description/srdf/panda.srdf",
        cache_dir=mesh_cache,
    )
    assert panda.model.nexclude > 10


def test_srdf_naming_an_unknown_link_is_an_error(tmp_path):
    srdf = tmp_path / "bad.srdf"
    srdf.write_text('<robot name="x">\n<disable_collisions link1="link0" link2="ghost"/>\n</robot>')
    with pytest.raises(ModelError, match=r"bad\.srdf: line 2: <disable_collisions>: link 'ghost'"):
        load_robot("demo", srdf=srdf)
