"""Collision meshes as Gazebo collides them (issue 33): a concave arena wall is convex pieces
within 2 cm of its triangles, cached by content, and ray casts still see its triangles;
``mesh_collision="hull"`` keeps MuJoCo's convex hull."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from harness.models import RobotSpec, load_world
from harness.models.build import decompose as decompose_module
from harness.models.errors import ModelStructureError, ModelWarning

SIDE, THICKNESS, HEIGHT = 5.0, 0.15, 0.5
"""The arena: a square ring wall 5 m on a side (one concave mesh, as turtlebot3's wall.dae)."""


def _wall() -> trimesh.Trimesh:
    outer = trimesh.creation.box((SIDE, SIDE, HEIGHT))
    inner = trimesh.creation.box((SIDE - 2 * THICKNESS, SIDE - 2 * THICKNESS, 2 * HEIGHT))
    wall = outer.difference(inner)
    wall.apply_translation((0.0, 0.0, HEIGHT / 2))
    return wall


@pytest.fixture(scope="module")
def arena(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("arena")
    _wall().export(folder / "wall.stl")
    (folder / "arena.xml").write_text(
        '<mujoco><asset><mesh name="wall" file="wall.stl"/></asset><worldbody>'
        '<geom name="floor" type="plane" size="5 5 0.1"/>'
        '<geom name="wall" type="mesh" mesh="wall"/></worldbody></mujoco>'
    )
    (folder / "arena.sdf").write_text(
        '<sdf version="1.9"><world name="arena"><model name="arena"><static>true</static>'
        '<link name="wall"><collision name="c"><geometry><mesh><uri>wall.stl</uri></mesh>'
        "</geometry></collision></link></model></world></sdf>"
    )
    (folder / "box.xml").write_text(
        '<mujoco model="box"><worldbody><body name="base" pos="0.5 0.3 0.1"><freejoint/>'
        '<geom name="shell" type="box" size=".1 .1 .1" mass="1"/></body></worldbody></mujoco>'
    )
    return folder


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cache")


def _load(arena: Path, cache: Path, scene: str = "arena.xml", **kwargs: object) -> mujoco.MjModel:
    world = load_world(
        [RobotSpec(str(arena / "box.xml"))], scene=str(arena / scene), cache_dir=cache, **kwargs
    )
    return world.model


def _wall_contacts(model: mujoco.MjModel, body: str = "box/base") -> list[tuple[str, str]]:
    """The box's contacts at the start with anything but the floor."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    box = model.body(body).id
    found = []
    for contact in data.contact[: data.ncon]:
        bodies = {int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])}
        names = (model.geom(contact.geom1).name, model.geom(contact.geom2).name)
        if box in bodies and "floor" not in names:
            found.append(names)
    return found


@pytest.mark.parametrize("scene", ["arena.xml", "arena.sdf"])
def test_a_box_inside_a_concave_wall_touches_nothing_but_the_floor(
    arena: Path, cache: Path, scene: str
) -> None:
    model = _load(arena, cache, scene)
    assert _wall_contacts(model) == []
    pieces = [g for g in range(model.ngeom) if "#" in model.geom(g).name]
    assert len(pieces) >= 4  # a ring is at least four convex walls


def test_hull_keeps_the_convex_hull(arena: Path, cache: Path) -> None:
    with pytest.warns(ModelWarning, match="contact"):
        model = _load(arena, cache, mesh_collision="hull")
    assert _wall_contacts(model)  # inside the hull: the wall's hull is solid
    assert not any("#" in model.geom(g).name for g in range(model.ngeom))


def test_mesh_collision_is_one_of_two_words(arena: Path, cache: Path) -> None:
    with pytest.raises(
        ModelStructureError,
        match=r"load_world: unknown mesh_collision 'convex' \(one of decompose, hull\)",
    ):
        _load(arena, cache, mesh_collision="convex")


def _piece_points(model: mujoco.MjModel) -> np.ndarray:
    """Vertices and surface samples of every piece geom, in world coordinates (from the
    compiled model, not from the decomposition's own data)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    points = []
    for g in range(model.ngeom):
        if "#" not in model.geom(g).name:
            continue
        mesh = int(model.geom_dataid[g])
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        fstart, fcount = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        local = trimesh.Trimesh(
            model.mesh_vert[start : start + count],
            model.mesh_face[fstart : fstart + fcount],
            process=False,
        )
        sampled, _ = trimesh.sample.sample_surface(local, 20000, seed=1)
        cloud = np.vstack([local.vertices, sampled])
        points.append(cloud @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g])
    return np.vstack(points)


def test_pieces_stay_within_2_cm_of_the_triangles(arena: Path, cache: Path) -> None:
    model = _load(arena, cache)
    wall = _wall()
    points = _piece_points(model)
    _, distance, _ = trimesh.proximity.closest_point(wall, points)
    distance[wall.contains(points)] = 0.0
    assert distance.max() <= 0.02


def test_a_second_load_does_not_decompose_again(
    arena: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[float] = []
    real = decompose_module._run_coacd

    def counting(*args: object) -> object:
        calls.append(1.0)
        return real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(decompose_module, "_run_coacd", counting)
    first = _load(arena, tmp_path)
    assert calls
    calls.clear()
    second = _load(arena, tmp_path)
    assert calls == []
    assert first.ngeom == second.ngeom
    assert np.array_equal(first.mesh_vert, second.mesh_vert)


def test_rays_see_the_mesh_triangles(arena: Path, cache: Path) -> None:
    """mj_ray from inside the arena (as the lidar casts) against trimesh's ray cast on the
    wall's triangles: the pieces are not seen, the triangles are."""
    model = _load(arena, cache)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    origin = np.array([0.5, 0.3, 0.25])
    angles = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    geomid = np.zeros(len(angles), np.int32)
    dist = np.zeros(len(angles))
    box = model.body("box/base").id
    mujoco.mj_multiRay(
        model, data, origin, directions.reshape(-1).copy(), None, 1, box,
        geomid, dist, None, len(angles), 10.0,
    )  # fmt: skip
    wall = _wall()
    hits, rays, _ = wall.ray.intersects_location(
        np.repeat(origin[None], len(angles), axis=0), directions, multiple_hits=False
    )
    expected = np.full(len(angles), np.inf)
    expected[rays] = np.linalg.norm(hits - origin, axis=1)
    assert np.all(np.isfinite(expected))
    assert np.max(np.abs(dist - expected)) < 1e-6
    assert {model.geom(int(g)).name for g in geomid} == {"wall"}
