"""A moving robot's concave link mesh collides as Gazebo collides it (issue 33): convex pieces
in the link's body, massless, under the link's self-collision exclusions, named after the
link; a peg between the prongs of a fork-shaped link touches the hull, not the pieces; the
recording carries the pieces, so its rebuild never decomposes; a cold load decomposes the
meshes in parallel processes, after one warning, with the entries a serial run writes."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import trimesh

from harness.events import CollectingSink, CollisionBegin, CollisionLogger
from harness.models import RobotSpec, WorldObject, load_robot, load_world
from harness.models.build import decompose as decompose_module
from harness.models.errors import ModelWarning
from harness.recording import Recording
from harness.replay.source import rebuild_run
from harness.session import Session

HEIGHT = 0.5
"""The fork's joint is this high above the floor (nothing of it touches the floor)."""
PEG = WorldObject("peg", "box", (0.02, 0.02, 0.02), pose=(0.0, 0.2, HEIGHT))
"""A fixed box between the fork's prongs: 8 cm clear of each."""
_INERTIAL = (
    '<inertial><mass value="{mass}"/>'
    '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
)


def _fork() -> trimesh.Trimesh:
    """A U in the link's xy plane opening towards +y: a back bar (y 0..0.05) and two prongs
    x in [-0.15, -0.10] and [0.10, 0.15], y up to 0.35, 10 cm thick. Its hull is solid
    between the prongs."""
    outer = trimesh.creation.box((0.30, 0.35, 0.10))
    outer.apply_translation((0.0, 0.175, 0.0))
    gap = trimesh.creation.box((0.20, 0.35, 0.20))
    gap.apply_translation((0.0, 0.225, 0.0))
    return outer.difference(gap)


def _hook() -> trimesh.Trimesh:
    """An L (another concave mesh, for the parallel run)."""
    outer = trimesh.creation.box((0.20, 0.20, 0.05))
    cut = trimesh.creation.box((0.16, 0.16, 0.10))
    cut.apply_translation((0.02, 0.02, 0.0))
    return outer.difference(cut)


def _robot(folder: Path, *, hook: bool = False) -> Path:
    """``base`` -turn-> ``fork`` (the U mesh) -tilt-> ``tip`` (a cube inside the right prong)
    -roll-> ``arm2`` (a cube inside the left prong: not adjacent to the fork); with ``hook``
    an L-shaped link on ``arm2`` too. An SRDF disables (fork, arm2)."""
    _fork().export(folder / "fork.stl")
    cube = '<collision><geometry><box size="0.02 0.02 0.02"/></geometry></collision>'
    links = [
        f'<link name="base">{_INERTIAL.format(mass=1)}</link>',
        f'<link name="fork">{_INERTIAL.format(mass=2)}'
        '<collision><geometry><mesh filename="fork.stl"/></geometry></collision></link>',
        f'<link name="tip">{_INERTIAL.format(mass=0.1)}{cube}</link>',
        f'<link name="arm2">{_INERTIAL.format(mass=0.1)}{cube}</link>',
    ]
    joints = [
        ("turn", "base", "fork", f"0 0 {HEIGHT}", "0 0 1"),
        ("tilt", "fork", "tip", "0.125 0.2 0", "1 0 0"),
        ("roll", "tip", "arm2", "-0.25 0 0", "0 1 0"),
    ]
    if hook:
        _hook().export(folder / "hook.stl")
        links.append(
            f'<link name="hook">{_INERTIAL.format(mass=0.1)}'
            '<collision><geometry><mesh filename="hook.stl"/></geometry></collision></link>'
        )
        joints.append(("swing", "arm2", "hook", "0 0 -0.3", "0 0 1"))
    text = "".join(
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
        f'<child link="{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        for name, parent, child, xyz, axis in joints
    )
    path = folder / ("hooked.urdf" if hook else "fork.urdf")
    path.write_text(f'<robot name="forked">{"".join(links)}{text}</robot>')
    (folder / "fork.srdf").write_text(
        '<robot name="forked"><disable_collisions link1="fork" link2="arm2" reason="Never"/>'
        "</robot>"
    )
    return path


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _robot(tmp_path_factory.mktemp("fork"))


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cache")


def _contacts(model: mujoco.MjModel) -> set[tuple[str, str, str, str]]:
    """(body1, body2, geom1, geom2) of every contact at the start, bodies sorted."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    found = set()
    for contact in data.contact[: data.ncon]:
        pair = sorted(
            (model.body(int(model.geom_bodyid[g])).name, model.geom(int(g)).name)
            for g in (contact.geom1, contact.geom2)
        )
        found.add((pair[0][0], pair[1][0], pair[0][1], pair[1][1]))
    return found


def _load(robot: Path, cache: Path, mesh_collision: str = "decompose", **kwargs: Any) -> Any:
    with warnings.catch_warnings():  # start contacts, first-load lines: not what is checked
        warnings.simplefilter("ignore", ModelWarning)
        world = load_world(
            [RobotSpec(str(robot), namespace="", **kwargs)],
            objects=[PEG],
            cache_dir=cache,
            mesh_collision=mesh_collision,  # type: ignore[arg-type]
        )
    return world.model


def test_a_peg_between_the_prongs_touches_the_hull_not_the_pieces(robot: Path, cache: Path) -> None:
    hull = _load(robot, cache, mesh_collision="hull", srdf=robot.parent / "fork.srdf")
    assert {c[:2] for c in _contacts(hull)} == {("fork", "peg")}
    decomposed = _load(robot, cache, srdf=robot.parent / "fork.srdf")
    assert _contacts(decomposed) == set()
    pieces = [g for g in range(decomposed.ngeom) if decomposed.geom(g).name.startswith("fork#")]
    assert len(pieces) >= 3  # a U is at least three convex bars
    fork = decomposed.body("fork").id
    assert {int(decomposed.geom_bodyid[g]) for g in pieces} == {fork}
    assert all(decomposed.geom_rgba[g][3] == 0.0 for g in pieces)  # unseen by rays, cameras
    # massless pieces: the link keeps its file's mass and inertia
    assert decomposed.body_mass[fork] == hull.body_mass[hull.body("fork").id] == 2.0
    assert np.array_equal(decomposed.body_inertia[fork], hull.body_inertia[hull.body("fork").id])


def test_pieces_keep_the_links_self_collision_exclusions(robot: Path, cache: Path) -> None:
    """The cubes sit inside the prongs: the tip's (adjacent) and arm2's (SRDF-disabled) touch
    the pieces of the fork, and neither collides; with every pair on, arm2's does, and the
    contact names the fork link and one of its pieces."""
    srdf = _load(robot, cache, srdf=robot.parent / "fork.srdf", self_collision="srdf")
    assert not [c for c in _contacts(srdf) if c[:2] != ("fork", "peg")]
    on = _load(robot, cache, self_collision="on")
    robot_contacts = {c for c in _contacts(on) if "peg" not in c[:2]}
    assert {c[:2] for c in robot_contacts} == {("arm2", "fork")}  # (fork, tip): adjacent
    assert all(c[3].startswith("fork#") for c in robot_contacts)


def test_a_collision_event_names_the_link(robot: Path, tmp_path: Path) -> None:
    sink = CollectingSink()

    def logger(session: Session) -> CollisionLogger:
        return CollisionLogger(session.model, robot_bodies=session.link_names)

    with (
        pytest.warns(ModelWarning),
        Session(
            robot,
            self_collision="on",
            controllers=False,
            loggers=[logger],
            sinks=[sink],
            clock="lockstep",
        ) as session,
    ):
        session.step(2)
    begins = [e for e in sink.events if isinstance(e, CollisionBegin)]
    assert begins
    event = begins[0]
    assert {event.body1, event.body2} == {"fork", "arm2"}
    fork_geom = event.geom1 if event.body1 == "fork" else event.geom2
    assert fork_geom.startswith("fork#")


def test_the_recording_carries_the_pieces_and_the_rebuild_never_decomposes(
    robot: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HARNESS_CACHE_DIR", str(tmp_path / "cache-recording"))
    path = tmp_path / "fork.mcap"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with Session(robot, record_to=path, controllers=False) as session:
            recorded = session.model
            session.step(5)
    assert [g for g in range(recorded.ngeom) if recorded.geom(g).name.startswith("fork#")]
    assert [w for w in caught if f"decomposing 1 mesh of {robot} (first load" in str(w.message)]
    rec = Recording(path)
    assert rec.metadata["mesh_collision"] == "decompose"
    attached = [n for n in rec.attachment_names if n.startswith("source/decomposition/")]
    assert len(attached) == 1

    def refuse(*args: object, **kwargs: object) -> object:
        raise AssertionError("decomposed again")

    monkeypatch.setenv("HARNESS_CACHE_DIR", str(tmp_path / "cache-replay"))
    monkeypatch.setattr(decompose_module, "_load", refuse)  # no mesh read to be measured
    rebuilt = rebuild_run(rec)
    assert rebuilt.model.ngeom == recorded.ngeom
    assert np.array_equal(rebuilt.model.mesh_vert, recorded.mesh_vert)
    assert not (tmp_path / "cache-replay").exists()


def test_a_cold_load_decomposes_in_processes_as_the_serial_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if decompose_module.workers_for(2) < 2:
        pytest.skip("one CPU: the meshes are decomposed in this process")
    path = _robot(tmp_path, hook=True)
    monkeypatch.setenv(decompose_module.WORKERS_VARIABLE, "1")
    serial = load_robot(path, cache_dir=tmp_path / "serial", mesh_collision="decompose")

    def refuse(*args: object, **kwargs: object) -> object:
        raise AssertionError("decomposed in the caller's process")

    monkeypatch.setenv(decompose_module.WORKERS_VARIABLE, "2")
    monkeypatch.setattr(decompose_module, "_coacd_pieces", refuse)  # the spawned workers' is real
    with pytest.warns(ModelWarning) as caught:
        parallel = load_robot(path, cache_dir=tmp_path / "parallel")
    lines = [str(w.message) for w in caught if "decomposing" in str(w.message)]
    assert lines == [
        f"decomposing 2 meshes of {path} (first load; cached in {tmp_path / 'parallel'}, "
        "2 processes)"
    ]
    entries = sorted(p.name for p in (tmp_path / "serial").glob("decompose-*.npz"))
    assert len(entries) == 2
    assert entries == sorted(p.name for p in (tmp_path / "parallel").glob("decompose-*.npz"))
    for name in entries:
        assert (tmp_path / "serial" / name).read_bytes() == (
            tmp_path / "parallel" / name
        ).read_bytes()
    assert np.array_equal(serial.model.mesh_vert, parallel.model.mesh_vert)
    assert serial.sha256 == parallel.sha256
