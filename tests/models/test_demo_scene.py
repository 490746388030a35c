"""The demo robot in its table scene: unprefixed names, a reachable box, exact records."""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

from harness.models import SCENES, load_robot


def _ik_to(m, d, body_name: str, point_local, target, iterations: int = 300) -> float:
    """Damped least squares on the arm joints (test helper, kinematics only); the error left."""
    joints = [m.joint(f"joint{i}").id for i in range(1, 8)]
    dofs = [int(m.jnt_dofadr[j]) for j in joints]
    body = m.body(body_name).id
    jacp = np.zeros((3, m.nv))
    error = np.full(3, np.inf)
    for _ in range(iterations):
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)  # mj_jac needs it
        point = d.xpos[body] + d.xmat[body].reshape(3, 3) @ point_local
        error = target - point
        if np.linalg.norm(error) < 1e-4:
            break
        mujoco.mj_jac(m, d, jacp, None, point, body)
        jac = jacp[:, dofs]
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(3), error)
        for joint, delta in zip(joints, step, strict=True):
            lo, hi = m.jnt_range[joint]
            adr = m.jnt_qposadr[joint]
            d.qpos[adr] = np.clip(d.qpos[adr] + delta, lo, hi)
    return float(np.linalg.norm(error))


def test_table_scene_layout_and_home_is_contact_free():
    loaded = load_robot("demo")
    m = loaded.model
    names = {m.body(b).name for b in range(m.nbody)}
    assert {"table", "box", "link0", "hand", "left_finger", "right_finger"} <= names
    assert m.opt.timestep == 0.002
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    robot = {m.body(link.name).id for link in loaded.description.links}
    for i in range(d.ncon):
        b1, b2 = (int(m.geom_bodyid[g]) for g in d.contact.geom[i])
        assert not {b1, b2} & robot, (m.body(b1).name, m.body(b2).name)
    assert d.xpos[m.body("box").id][2] > 0.3


def test_box_is_reachable_by_the_fingers():
    m = load_robot("demo").model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_kinematics(m, d)
    box = d.xpos[m.body("box").id].copy()
    # the finger pad's centre 2 cm above the box centre: inside the box's top half
    left = _ik_to(
        m, d, "left_finger", np.array([0, 0.0105, 0.027]), box + np.array([0.0, 0.0, 0.02])
    )
    assert left < 1e-3
    mujoco.mj_forward(m, d)
    finger = m.body("left_finger").id
    touching = any(
        finger in {int(m.geom_bodyid[g]) for g in d.contact.geom[i]}
        and m.body("box").id in {int(m.geom_bodyid[g]) for g in d.contact.geom[i]}
        for i in range(d.ncon)
    )
    assert touching


def test_records_for_recording(tmp_path):
    loaded = load_robot("demo", scene="empty")
    assert set(loaded.sources) == {"model/demo_arm.urdf", "scene/empty.xml"}
    assert loaded.sources["scene/empty.xml"] == SCENES["empty"].read_bytes()
    assert loaded.sha256 == hashlib.sha256(loaded.mjcf.encode()).hexdigest()
    assert loaded.name == "demo_arm"
    # the exact binary model round-trips bit for bit; the MJCF text compiles to the same shape
    path = tmp_path / "model.mjb"
    path.write_bytes(loaded.mjb)
    exact = mujoco.MjModel.from_binary_path(str(path))
    assert np.array_equal(exact.body_pos, loaded.model.body_pos)
    assert np.array_equal(exact.actuator_gainprm, loaded.model.actuator_gainprm)
    text = mujoco.MjModel.from_xml_string(loaded.mjcf)
    assert (text.nbody, text.nq, text.nu) == (loaded.model.nbody, loaded.model.nq, loaded.model.nu)
    # same inputs, same model text
    assert load_robot("demo", scene="empty").sha256 == loaded.sha256


def test_scene_none_gives_a_floor_and_user_scene_files_work(tmp_path, data_dir):
    alone = load_robot(data_dir / "rotated_chain.urdf")
    assert alone.model.geom("floor").id >= 0
    world = tmp_path / "world.xml"
    world.write_text(
        '<mujoco><option timestep="0.001"/><worldbody>'
        '<geom name="ground" type="plane" size="1 1 0.1"/></worldbody></mujoco>'
    )
    placed = load_robot(data_dir / "rotated_chain.urdf", scene=world)
    assert placed.model.opt.timestep == 0.001
    assert placed.model.geom("ground").id >= 0
    assert "scene/world.xml" in placed.sources


def test_mjcf_source_is_loaded_as_is(tmp_path):
    path = tmp_path / "arm.xml"
    path.write_text(
        '<mujoco model="arm"><compiler angle="radian"/><worldbody><body name="upper" pos="0 0 1">'
        '<joint name="shoulder" axis="0 1 0" range="-1 1"/><geom type="capsule" size="0.05" '
        'fromto="0 0 0 0.5 0 0"/></body></worldbody>'
        '<actuator><position joint="shoulder" kp="50"/></actuator></mujoco>'
    )
    loaded = load_robot(path)
    assert loaded.model.nu == 1
    assert dict(loaded.control) == {"shoulder": "position"}
    assert loaded.description.format == "mjcf"
    joint = loaded.description.joint("shoulder")
    assert joint.axis == (0.0, 1.0, 0.0)
    assert (joint.limits.lower, joint.limits.upper) == (-1.0, 1.0)
    assert loaded.description.link("upper").pose.xyz == (0.0, 0.0, 1.0)
