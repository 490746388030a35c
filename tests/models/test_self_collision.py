"""Self-collision policy, placement and base: which link pairs collide, MoveIt- or
Gazebo-style, deterministic and recorded; robots lifted out of the floor or set down on it."""

from __future__ import annotations

import json
import warnings

import mujoco
import numpy as np
import pytest

from harness.models import load_robot
from harness.models.build.selfcollision import SAMPLES
from harness.models.errors import ModelStructureError, ModelWarning
from harness.recording.describe import describe_run
from tests.models.paths import robots_dir

from .conftest import DATA

ARM = DATA / "overlapping_arm.urdf"
KINOVA = "kinova_description/robots/kinova.urdf"


def _quiet(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        return load_robot(path, **options)


def _pairs(loaded):
    return {(p.link1, p.link2): p.reason for p in loaded.self_collision.ignored}


def _robot_contacts(loaded, qpos=None):
    m = loaded.model
    d = mujoco.MjData(m)
    if m.nkey:  # the initial configuration
        mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    if qpos is not None:
        d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    robot = {m.body(link.name).id for link in loaded.description.links}
    found = set()
    for i in range(d.ncon):
        b1, b2 = (int(m.geom_bodyid[g]) for g in d.contact.geom[i])
        if b1 in robot and b2 in robot:
            found.add(tuple(sorted((m.body(b1).name, m.body(b2).name))))
    return found


def test_auto_ignores_adjacent_and_initially_touching_pairs_and_says_why():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loaded = load_robot(ARM)
    assert loaded.self_collision.policy == "auto"
    assert loaded.self_collision.origin == "default"
    assert _pairs(loaded) == {
        ("base", "shoulder"): "adjacent",
        ("shoulder", "forearm"): "adjacent",
        ("base", "forearm"): "default",
    }
    assert not _robot_contacts(loaded)
    assert not [w for w in caught if "at the start" in str(w.message)]


def test_on_keeps_the_overlap_and_reports_it_once_off_ignores_every_pair():
    with pytest.warns(ModelWarning, match=r"1 contact\(s\) at the start: base / forearm 20\.0 mm"):
        on = load_robot(ARM, self_collision="on")
    assert set(_pairs(on).values()) == {"adjacent"}
    assert _robot_contacts(on) == {("base", "forearm")}
    off = _quiet(ARM, self_collision="off")
    assert _pairs(off)[("base", "forearm")] == "off"
    assert not _robot_contacts(off)


def test_self_collide_in_the_file_chooses_the_policy(tmp_path):
    text = ARM.read_text()
    for value, policy in (("false", "off"), ("true", "on")):
        path = tmp_path / f"arm_{value}.urdf"
        path.write_text(
            text.replace(
                "</robot>", f"<gazebo><self_collide>{value}</self_collide></gazebo></robot>"
            )
        )
        loaded = _quiet(path)
        assert (loaded.self_collision.policy, loaded.self_collision.origin) == (policy, "file")
    # an argument wins over the file
    assert _quiet(path, self_collision="auto").self_collision.policy == "auto"


def test_unknown_policy_and_srdf_policy_without_srdf_are_refused():
    with pytest.raises(ModelStructureError, match="unknown self_collision 'sometimes'"):
        load_robot(ARM, self_collision="sometimes")  # type: ignore[arg-type]
    with pytest.raises(ModelStructureError, match="self_collision='srdf' but no srdf"):
        load_robot(ARM, self_collision="srdf")


def test_a_real_robot_starts_free_of_self_contact_and_pairs_not_ignored_still_collide(mesh_cache):
    """The Kinova starts with 71 contacts when every pair collides; with "auto" none, and its
    links can still hit each other: the ignored list is not everything. (Its link meshes as
    their hulls: decomposed, "on" starts with 3 contacting pairs only.)"""
    path = robots_dir() / KINOVA
    on = _quiet(path, self_collision="on", cache_dir=mesh_cache, mesh_collision="hull")
    auto = _quiet(path, cache_dir=mesh_cache, mesh_collision="hull")
    assert len(_robot_contacts(on)) > 3
    assert not _robot_contacts(auto)
    ignored = set(_pairs(auto))
    rng = np.random.default_rng(1)
    m = auto.model
    hinges = [j for j in range(m.njnt) if m.jnt_limited[j]]
    hits: set[tuple[str, str]] = set()
    for _ in range(300):
        qpos = np.array(m.qpos0)
        for j in hinges:
            qpos[m.jnt_qposadr[j]] = rng.uniform(*m.jnt_range[j])
        hits |= _robot_contacts(auto, qpos)
    assert hits, "no self-collision in 300 random configurations"
    assert not {(a, b) for a, b in hits} & ignored


def test_pairs_are_deterministic_and_recorded_in_the_metadata(mesh_cache):
    path = robots_dir() / KINOVA
    # as hulls: its six concave link meshes take 1-2 min to decompose cold (the pieces are
    # the same every time: test_robot_mesh_decomposition; the UR5 below is decomposed)
    first = _quiet(path, cache_dir=mesh_cache, mesh_collision="hull")
    second = _quiet(path, cache_dir=mesh_cache, mesh_collision="hull")
    assert first.self_collision == second.self_collision
    assert first.mjb == second.mjb
    assert SAMPLES >= 100
    metadata = describe_run(first).metadata
    recorded = json.loads(metadata["self_collision"])
    assert recorded["policy"] == "auto"
    assert recorded["ignored"] == [
        [p.link1, p.link2, p.reason] for p in first.self_collision.ignored
    ]
    assert metadata["base"] == "fixed"


def test_a_fixed_robot_is_lifted_out_of_the_floor(mesh_cache):
    """The UR5 at its zero configuration reaches 48.5 mm through the floor: lifted, with a
    notice; the base alone touching the floor (the Panda) is not a reason to lift."""
    with pytest.warns(ModelWarning, match=r"reach 0\.0485 m through the floor.*lifted 0\.0495 m"):
        ur5 = load_robot(robots_dir() / "ur_description/urdf/ur5_robot.urdf", cache_dir=mesh_cache)
    assert ur5.placement.xyz[2] == pytest.approx(0.0495, abs=1e-4)
    assert not _robot_contacts(ur5)
    d = mujoco.MjData(ur5.model)
    mujoco.mj_forward(ur5.model, d)
    assert d.ncon == 0  # nothing touches the floor either
    panda = _quiet(robots_dir() / "panda_description/urdf/panda.urdf", cache_dir=mesh_cache)
    assert panda.placement.xyz == (0.0, 0.0, 0.0)


def test_a_floating_robot_is_set_down_on_the_floor(mesh_cache):
    go1 = _quiet(
        robots_dir() / "go1_description/urdf/go1.urdf", base="floating", cache_dir=mesh_cache
    )
    assert go1.base == "floating"
    m = go1.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    floor = m.geom("floor").id
    robot_geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
    gap = min(mujoco.mj_geomDistance(m, d, floor, g, 1.0, None) for g in robot_geoms)
    assert abs(gap) < 1e-6  # lowest point on the floor, not above, not through
    with pytest.raises(ModelStructureError, match="fixes the robot to a link named 'world'"):
        load_robot(DATA / "floating_world.urdf", base="floating")


def test_a_recording_rebuilds_with_its_self_collision_policy(tmp_path):
    """The policy is recorded; replay rebuilds the same model from the sources with it."""
    from harness.recording import Recording
    from harness.replay.source import rebuild_robot
    from harness.session import Session

    loaded = _quiet(ARM, self_collision="off")
    path = tmp_path / "off.mcap"
    with Session(loaded, record_to=path) as session:
        session.step(5)
    with Recording(path) as rec:
        assert json.loads(rec.metadata["self_collision"])["policy"] == "off"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            rebuilt = rebuild_robot(rec)
    assert rebuilt.self_collision == loaded.self_collision
    assert rebuilt.mjb == loaded.mjb


def test_auto_policy_samples_ranges_wider_than_a_float_can_span(tmp_path):
    """Limits of +-1e308 (found by the URDF fuzzer: numpy cannot sample high - low) load;
    the hinge is sampled within a turn, the slide within its window."""
    link = (
        '<link name="{0}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" '
        'ixz="0" iyz="0"/></inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry>'
        "</collision></link>"
    )
    urdf = tmp_path / "wide.urdf"
    urdf.write_text(
        '<robot name="wide"><link name="base"/>'
        + link.format("arm")
        + link.format("arm2")
        + '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>'
        '<limit lower="-1e308" upper="1e308" effort="1" velocity="1"/></joint>'
        '<joint name="k" type="prismatic"><parent link="arm"/><child link="arm2"/>'
        '<limit lower="50" upper="1e308" effort="1" velocity="1"/></joint></robot>'
    )
    with pytest.warns(ModelWarning):
        robot = load_robot(urdf, self_collision="auto")
    assert robot.model.njnt == 2


def _with_gazebo(tmp_path, name, blocks):
    path = tmp_path / f"{name}.urdf"
    path.write_text(ARM.read_text().replace("</robot>", f"{blocks}</robot>"))
    return path


def _gazebo(value, link=None):
    reference = f' reference="{link}"' if link else ""
    return f"<gazebo{reference}><self_collide>{value}</self_collide></gazebo>"


def test_a_link_self_collide_is_honoured_as_gazebo_does(tmp_path):
    # the model says off, the forearm says true: the forearm collides with the base
    path = _with_gazebo(tmp_path, "forearm_on", _gazebo("false") + _gazebo("true", "forearm"))
    with pytest.warns(ModelWarning, match=r"contact\(s\) at the start: base / forearm"):
        loaded = load_robot(path)
    assert (loaded.self_collision.policy, loaded.self_collision.origin) == ("off", "file")
    assert set(_pairs(loaded).values()) == {"adjacent"}
    assert _robot_contacts(loaded) == {("base", "forearm")}
    # the model says on, both links say false: that pair is ignored (SDFormat: either true)
    path = _with_gazebo(
        tmp_path, "both_off", _gazebo("true") + _gazebo("0", "base") + _gazebo("0", "forearm")
    )
    loaded = _quiet(path)
    assert _pairs(loaded)[("base", "forearm")] == "link"
    assert not _robot_contacts(loaded)
    # one link false, the other true by the model's setting: they collide
    path = _with_gazebo(tmp_path, "one_off", _gazebo("true") + _gazebo("false", "forearm"))
    assert _robot_contacts(_quiet(path)) == {("base", "forearm")}
    # a policy passed as an argument overrides the file, per-link settings included
    path = _with_gazebo(tmp_path, "argument", _gazebo("true", "forearm"))
    assert _pairs(_quiet(path, self_collision="off"))[("base", "forearm")] == "off"


def test_sdf_links_self_collide_are_read():
    from harness.models.build.selfcollision import declared_link_self_collide
    from harness.models.files.xmlsafe import read_xml_file

    path = DATA.parent / "gazebo_models/double_pendulum_with_base/model.sdf"
    root = read_xml_file(path)[0]
    assert declared_link_self_collide(root) == {"upper_link": False, "lower_link": False}


def test_a_link_self_collide_survives_record_and_rebuild(tmp_path):
    from harness.recording import Recording
    from harness.replay.source import rebuild_robot
    from harness.session import Session

    path = _with_gazebo(tmp_path, "forearm_on", _gazebo("false") + _gazebo("true", "forearm"))
    record = tmp_path / "run.mcap"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        with Session(path, record_to=record) as session:
            sha = session.robot.sha256
            session.step(5)
        rebuilt = rebuild_robot(Recording(record))
    assert rebuilt.sha256 == sha
    assert set(_pairs(rebuilt).values()) == {"adjacent"}
