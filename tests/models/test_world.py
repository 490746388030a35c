"""Several robots in one world: prefixed names, placements, address maps, keyframes, errors."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness.errors import ModelError
from harness.models import (
    DuplicateNamespaceError,
    InvalidNamespaceError,
    LoadedWorld,
    Pose,
    RobotSpec,
    WorldObject,
    load_robot,
    load_world,
)
from harness.models.errors import CompileError, ModelStructureError

DATA = Path(__file__).resolve().parents[1] / "data" / "models"
LEFT = Pose.from_xyz_rpy((0.0, 0.45, 0.0), (0.0, 0.0, 0.0))
RIGHT = Pose.from_xyz_rpy((0.1, -0.45, 0.02), (0.05, -0.1, 2.5))
DEMO_JOINTS = [f"joint{i}" for i in range(1, 8)] + ["finger_joint1", "finger_joint2"]


@pytest.fixture(scope="module")
def two_arms() -> LoadedWorld:
    return load_world(
        [
            RobotSpec("demo", namespace="left", pose=LEFT),
            RobotSpec("demo", namespace="right", pose=[*RIGHT.xyz, *RIGHT.quat]),
        ]
    )


@pytest.fixture(scope="module")
def single() -> mujoco.MjModel:
    return load_robot("demo").model


def test_two_demo_arms_compile_with_prefixed_names(two_arms: LoadedWorld) -> None:
    model = two_arms.model
    assert model.nq == 7 + 2 * 9  # the table scene's free box, then both arms
    for namespace in ("left", "right"):
        view = two_arms.robot(namespace)
        assert [a.name for a in view.joints.values()] == [f"{namespace}/{j}" for j in DEMO_JOINTS]
        for link in view.description.links:
            assert model.body(view.bodies[link.name]).name == f"{namespace}/{link.name}"
        for joint, actuator in view.actuators.items():
            assert model.actuator(actuator).name == f"{namespace}/{joint}"
        geoms = [model.geom(g).name for g in range(model.ngeom)]
        assert f"{namespace}/link0_base" in geoms
    # the mimic finger is an equality constraint per arm, between that arm's joints
    assert model.neq == 2
    for eq in range(model.neq):
        first = model.joint(int(model.eq_obj1id[eq])).name.split("/")[0]
        second = model.joint(int(model.eq_obj2id[eq])).name.split("/")[0]
        assert first == second
    assert two_arms.robot("left").description.joint("joint4").name == "joint4"
    assert two_arms.actuated == tuple(
        f"{ns}/{j}" for ns in ("left", "right") for j in DEMO_JOINTS[:-1]
    )
    assert set(two_arms.control) == set(two_arms.actuated)
    assert sorted(two_arms.sources) == [
        "model/left/demo_arm.urdf",
        "model/right/demo_arm.urdf",
        "scene/table.xml",
    ]
    with pytest.raises(KeyError, match="'left', 'right'"):
        two_arms.robot("middle")


def _random_configuration(
    model: mujoco.MjModel, rng: np.random.Generator, joints: list[str]
) -> dict[str, float]:
    config = {}
    for name in joints:
        low, high = model.joint(name).range
        config[name] = float(rng.uniform(low, high))
    return config


def test_each_arm_fk_is_the_single_arm_fk_moved_by_its_placement(
    two_arms: LoadedWorld, single: mujoco.MjModel
) -> None:
    rng = np.random.default_rng(3)
    world_data, single_data = mujoco.MjData(two_arms.model), mujoco.MjData(single)
    worst = 0.0
    for _ in range(20):
        for view, placement in ((two_arms.robot("left"), LEFT), (two_arms.robot("right"), RIGHT)):
            assert view.placement.is_close(placement, atol=1e-15)
            config = _random_configuration(single, rng, DEMO_JOINTS)
            for name, value in config.items():
                single_data.qpos[single.joint(name).qposadr[0]] = value
                world_data.qpos[view.joints[name].qpos] = value
            mujoco.mj_kinematics(single, single_data)
            mujoco.mj_kinematics(two_arms.model, world_data)
            rotation = placement.rotation_matrix()
            for link in view.description.links:
                alone = single.body(link.name).id
                placed = view.bodies[link.name]
                expected_pos = placement.transform_point(single_data.xpos[alone])
                expected_rot = rotation @ single_data.xmat[alone].reshape(3, 3)
                worst = max(
                    worst,
                    float(np.max(np.abs(world_data.xpos[placed] - expected_pos))),
                    float(np.max(np.abs(world_data.xmat[placed].reshape(3, 3) - expected_rot))),
                )
    assert worst <= 1e-12


def test_joint_set_through_the_map_reads_back_by_mujoco_name(two_arms: LoadedWorld) -> None:
    model, data = two_arms.model, mujoco.MjData(two_arms.model)
    left, right = two_arms.robot("left"), two_arms.robot("right")
    data.qpos[left.joints["joint2"].qpos] = 0.25
    data.qpos[right.joints["joint2"].qpos] = -0.5
    data.qvel[right.joints["joint6"].qvel] = 1.5
    assert data.joint("left/joint2").qpos[0] == 0.25
    assert data.joint("right/joint2").qpos[0] == -0.5
    assert data.joint("right/joint6").qvel[0] == 1.5
    assert data.joint("left/joint6").qvel[0] == 0.0
    address = right.joints["finger_joint1"]
    assert (address.id, address.nq, address.nv) == (model.joint("right/finger_joint1").id, 1, 1)
    assert right.mujoco_name("link7") == "right/link7"


def test_combined_home_keyframe_holds_both_arms(
    two_arms: LoadedWorld, single: mujoco.MjModel
) -> None:
    model = two_arms.model
    assert [model.key(k).name for k in range(model.nkey)] == ["home"]
    home = model.key("home")
    single_home = single.key("home")
    for view in two_arms.robots:
        for name in DEMO_JOINTS:
            expected = single_home.qpos[single.joint(name).qposadr[0]]
            assert home.qpos[view.joints[name].qpos] == expected
            assert view.home[name] == expected
        for joint, actuator in view.actuators.items():
            assert home.ctrl[actuator] == single_home.ctrl[single.actuator(joint).id]
    box = model.joint("box_joint").qposadr[0]
    np.testing.assert_array_equal(home.qpos[box : box + 7], model.qpos0[box : box + 7])


def test_arms_hold_home_under_their_servos(two_arms: LoadedWorld) -> None:
    model, data = two_arms.model, mujoco.MjData(two_arms.model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    for _ in range(300):
        mujoco.mj_step(model, data)
    for view in two_arms.robots:
        for name in DEMO_JOINTS[:7]:
            assert abs(data.qpos[view.joints[name].qpos] - view.home[name]) < 0.02, name


def test_a_servo_moves_only_its_own_arm(two_arms: LoadedWorld) -> None:
    model, data = two_arms.model, mujoco.MjData(two_arms.model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    left, right = two_arms.robot("left"), two_arms.robot("right")
    data.ctrl[left.actuators["joint1"]] = 0.3
    for _ in range(500):
        mujoco.mj_step(model, data)
    assert abs(data.qpos[left.joints["joint1"].qpos] - 0.3) < 0.02
    assert abs(data.qpos[right.joints["joint1"].qpos]) < 1e-3


def test_overlapping_arms_collide_with_each_other() -> None:
    # Same base pose: not an error (bases are fixed to the world, they never make contacts);
    # the moving links of the two arms are not excluded from colliding.
    world = load_world(
        [RobotSpec("demo", namespace="a"), RobotSpec("demo", namespace="b")], scene="empty"
    )
    model, data = world.model, mujoco.MjData(world.model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    pairs = set()
    for contact in data.contact[: data.ncon]:
        names = sorted(
            model.body(int(model.geom_bodyid[g])).name for g in (contact.geom1, contact.geom2)
        )
        pairs.add(tuple(names))
    across = {p for p in pairs if p[0].split("/")[0] != p[1].split("/")[0]}
    assert ("a/link3", "b/link3") in across
    assert ("a/link0", "b/link0") not in pairs


def test_each_robot_has_its_own_srdf_excludes() -> None:
    srdf = DATA / "demo_arm.srdf"
    world = load_world(
        [
            RobotSpec("demo", namespace="a", pose=[0, 0.5, 0], srdf=srdf),
            RobotSpec("demo", namespace="b", pose=[0, -0.5, 0]),
        ]
    )
    model = world.model
    excluded = set()
    for signature in model.exclude_signature:
        body1, body2 = int(signature) >> 16, int(signature) & 0xFFFF
        excluded.add(tuple(sorted((model.body(body1).name, model.body(body2).name))))
    # the SRDF's pairs for a, adjacent links welded together for both (hand on link7)
    assert {("a/link0", "a/link2"), ("a/link5", "a/link7")} <= excluded
    assert ("b/link0", "b/link2") not in excluded
    assert all(x.split("/")[0] == y.split("/")[0] for x, y in excluded)  # no cross-robot pair
    assert world.robot("a").self_collision.policy == "srdf"
    assert world.robot("b").self_collision.policy == "auto"
    assert "srdf/a/demo_arm.srdf" in world.sources
    assert set(world.robot("a").sources) == {"model/a/demo_arm.urdf", "srdf/a/demo_arm.srdf"}


def test_default_namespace_is_the_robot_name_and_must_be_unique() -> None:
    world = load_world([RobotSpec("demo")], scene="empty")
    assert world.robots[0].namespace == "demo_arm"
    assert world.model.joint("demo_arm/joint1").id >= 0
    with pytest.raises(DuplicateNamespaceError) as error:
        load_world([RobotSpec("demo"), RobotSpec("demo")])
    message = str(error.value)
    assert "robots[1]" in message
    assert "'demo_arm' is already robots[0]'s" in message
    assert "\n" not in message


@pytest.mark.parametrize("namespace", ["1arm", "a/b", "a b", "arm-1", "bré"])
def test_invalid_namespace_is_refused(namespace: str) -> None:
    with pytest.raises(InvalidNamespaceError, match=r"robots\[1\].*not a ROS name segment"):
        load_world([RobotSpec("demo", namespace="ok"), RobotSpec("demo", namespace=namespace)])


@pytest.mark.parametrize(
    ("pose", "expected"),
    [([1, 2], "has 2 numbers"), ([0, 0, 0, 0, 0, 0, 0], "zero quaternion"), ("abc", "not a Pose")],
)
def test_bad_pose_is_one_line(pose: object, expected: str) -> None:
    with pytest.raises(ModelStructureError, match=expected) as error:
        load_world([RobotSpec("demo", namespace="a", pose=pose)])  # type: ignore[arg-type]
    assert "\n" not in str(error.value)


def test_pose_and_initial_positions_for_a_single_robot(single: mujoco.MjModel) -> None:
    pose = Pose.from_xyz_rpy((0.2, -0.1, 0.05), (0.0, 0.0, math.pi / 2))
    robot = load_robot("demo", pose=pose, initial_positions={"joint1": 0.5, "finger_joint1": 0.01})
    model = robot.model
    assert model.joint("joint1").id >= 0  # one robot: names stay unprefixed
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.xpos[model.body("link0").id], pose.xyz, atol=1e-15)
    home = model.key("home")
    assert home.qpos[model.joint("joint1").qposadr[0]] == 0.5
    assert home.ctrl[model.actuator("joint1").id] == 0.5
    assert home.ctrl[model.actuator("finger_joint1").id] == 0.01
    assert (
        home.qpos[model.joint("joint4").qposadr[0]]
        == single.key("home").qpos[single.joint("joint4").qposadr[0]]
    )
    # the servos stay tuned at the source's own home: the gains without the override (up to
    # rounding: the rotated base changes the mass matrix's last bits)
    np.testing.assert_allclose(model.actuator_gainprm, single.actuator_gainprm, rtol=1e-12)
    shifted = load_robot("demo", initial_positions={"joint1": 0.5})
    np.testing.assert_array_equal(shifted.model.actuator_gainprm, single.actuator_gainprm)
    with pytest.raises(ModelStructureError, match=r"initial_positions name no hinge.*'nope'"):
        load_robot("demo", initial_positions={"nope": 1.0})


def test_identity_pose_keeps_the_model_bytes() -> None:
    assert load_robot("demo", pose=Pose()).mjb == load_robot("demo").mjb
    assert load_robot("demo", pose=[0, 0, 0]).mjb == load_robot("demo").mjb


def test_objects_and_timestep() -> None:
    world = load_world(
        [RobotSpec("demo", namespace="arm")],
        scene="floor",
        objects=[
            WorldObject("crate", "box", (0.05, 0.05, 0.05), pose=[0.4, 0.3, 0.05], mass=0.5),
            WorldObject("post", "cylinder", (0.02, 0.3), pose=[0.6, -0.3, 0.3]),
        ],
        timestep=0.001,
    )
    model = world.model
    assert model.opt.timestep == 0.001
    assert model.joint("crate_joint").qposadr[0] == 0  # free objects come before the robot
    assert world.robot("arm").joints["joint1"].qpos == 7
    assert model.body("post").weldid == 0  # no mass: fixed
    assert model.key("home").qpos[:3].tolist() == [0.4, 0.3, 0.05]
    with pytest.raises(ModelStructureError, match=r"objects\[0\].*needs 1 positive sizes"):
        load_world([RobotSpec("demo")], objects=[WorldObject("ball", "sphere", (0.1, 0.2))])
    with pytest.raises(ModelStructureError, match=r"timestep -0\.1 is not positive"):
        load_world([RobotSpec("demo")], timestep=-0.1)


def test_mjcf_robots_keep_their_own_keys_and_actuators_in_a_world() -> None:
    compiled = DATA / "demo_compiled.xml"
    alone = load_robot(compiled)
    world = load_world(
        [
            RobotSpec(compiled, namespace="m"),
            RobotSpec(DATA / "two_link.xml", namespace="t", pose=[1, 0, 0], control="velocity"),
        ],
        scene="empty",
    )
    model = world.model
    assert [model.key(k).name for k in range(model.nkey)] == ["home"]
    m, t = world.robot("m"), world.robot("t")
    for name in DEMO_JOINTS:
        assert m.home[name] == alone.model.key("home").qpos[alone.model.joint(name).qposadr[0]]
    for joint, actuator in m.actuators.items():
        assert (
            model.key("home").ctrl[actuator]
            == alone.model.key("home").ctrl[alone.model.actuator(joint).id]
        )
    assert dict(t.control) == {"shoulder": "velocity", "elbow": "velocity"}
    assert model.actuator(t.actuators["elbow"]).name == "t/elbow"
    assert model.site("t/tip").id >= 0
    assert dict(t.home) == {"shoulder": 0.0, "elbow": 0.0}


def test_model_errors_name_the_robot() -> None:
    with pytest.raises(ModelError, match=r"robots\[1\].*gains name joints.*'nope'"):
        load_world(
            [RobotSpec("demo", namespace="a"), RobotSpec("demo", namespace="b", gains={"nope": 1})]
        )
    with pytest.raises(ModelStructureError, match="no robots"):
        load_world([])


def test_attach_name_clash_is_one_model_error() -> None:
    # the compiled demo MJCF brings its own "grid" texture, as the table scene does
    with pytest.raises(CompileError, match=r"cannot attach the robot into the scene.*'grid'"):
        load_robot(DATA / "demo_compiled.xml", scene="table")


def test_combined_description_is_the_world_at_zero_configuration(two_arms: LoadedWorld) -> None:
    combined = two_arms.combined_description()
    model, data = two_arms.model, mujoco.MjData(two_arms.model)
    data.qpos[:] = 0.0
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    worst = 0.0
    for view in two_arms.robots:
        for link in view.description.links:
            pose = combined.link(view.mujoco_name(link.name)).pose
            body = view.bodies[link.name]
            worst = max(worst, float(np.max(np.abs(data.xpos[body] - pose.xyz))))
        for joint in view.description.joints:
            described = combined.joint(view.mujoco_name(joint.name))
            assert described.limits == joint.limits
            if joint.type == "fixed":
                continue  # no MuJoCo joint
            address = view.joints[joint.name]
            worst = max(worst, float(np.max(np.abs(data.xaxis[address.id] - described.axis))))
            worst = max(worst, float(np.max(np.abs(data.xanchor[address.id] - described.pose.xyz))))
    assert worst <= 1e-12
    follower = combined.joint("right/finger_joint2")
    assert follower.mimic is not None
    assert follower.mimic.joint == "right/finger_joint1"


def test_todays_simulation_runs_a_world(two_arms: LoadedWorld) -> None:
    from harness.sim import Simulation

    world = load_world(
        [
            RobotSpec("demo", namespace="left", pose=LEFT),
            RobotSpec("demo", namespace="right", pose=RIGHT, control="kinematic"),
        ]
    )
    sim = Simulation.from_model(
        world.model, control=world.control, description=world.combined_description()
    )
    assert sim.kinematic_joints[0] == "right/joint1"
    sim.command("left/joint1", position=0.3)
    sim.set_positions({"right/joint1": -0.3})
    sim.step(400)
    positions = dict(zip(sim.joint_names, sim.joint_positions(), strict=True))
    assert abs(positions["left/joint1"] - 0.3) < 0.02
    assert positions["right/joint1"] == pytest.approx(-0.3, abs=1e-9)
