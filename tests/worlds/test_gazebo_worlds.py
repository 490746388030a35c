"""Gazebo worlds as users have them (issue 33), each with a TurtleBot3 where its launch puts
it: turtlebot3_simulations' ``turtlebot3_world`` and ``turtlebot3_house`` with the burger and
the waffle at the launch pose (``x_pose`` -2.0, ``y_pose`` -0.5, z 0.01 in both
``turtlebot3_world.launch.py`` and ``turtlebot3_house.launch.py``), a gz-sim world with the
Fuel ``Ground Plane`` and ``Sun`` includes (read from a fake Fuel cache), and a Gazebo Classic
world of ``model://`` library models placed by its ``<state>``.

For each: only support contacts at the start, <= 1 mm of drift in 10 s idle, the first
``/scan`` against an independent ray cast, a square driven through ``/cmd_vel`` back to the
start, a wheel driven into a wall failing the default verdict, and the recording replayed at
``--level full`` with no model path (nor Fuel cache) set. The robots are driven through
``/cmd_vel``: the DiffDrive plugin of their model.sdf gets a velocity-driven diff drive
controller.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tests.worlds.realworld import (
    DATA,
    HOUSE_DECOMPOSITION,
    TB3,
    TB3_MODELS,
    Run,
    open_run,
    ray_cast_ranges,
    world_triangles,
)

LAUNCH_POSE = (-2.0, -0.5, 0.01)
BURGER = TB3_MODELS / "turtlebot3_burger" / "model.sdf"
WAFFLE = TB3_MODELS / "turtlebot3_waffle" / "model.sdf"
FUEL_WORLD = DATA / "gz_fuel" / "fuel_room.sdf"
CLASSIC_WORLD = DATA / "classic" / "cafe.world"
STOCK = Path(__file__).resolve().parents[2] / "harness" / "models" / "data" / "gazebo_models"
PATH_VARIABLES = (
    "GZ_SIM_RESOURCE_PATH",
    "IGN_GAZEBO_RESOURCE_PATH",
    "GAZEBO_MODEL_PATH",
    "SDF_PATH",
    "GZ_FUEL_CACHE_PATH",
    "IGN_FUEL_CACHE_PATH",
)


@dataclass(frozen=True)
class Case:
    """A world, a robot at its pose, the model path its launch sets, the square driven from
    the start (corners relative to it, free of obstacles), and a pose beside a wall heading 20
    degrees into it with ``wheel`` (it sticks out of the base) on the wall's side."""

    world: Path
    robot: Path
    pose: tuple[float, ...]
    model_path: Path | None
    wall_pose: tuple[float, ...]
    wheel: str = "wheel_right"
    square: tuple[tuple[float, float], ...] = ((0.4, 0.0), (0.4, 0.4), (0.0, 0.4), (0.0, 0.0))
    fuel: bool = False
    mesh_collision: str = "decompose"


# turtlebot3_world: the arena's inner face at y = -2.54 between x = -1.47 and 1.47 (the
# hexagon wall.dae, inches at scale 0.25, turned by -90 degrees)
AT_WORLD_WALL = (0.0, -2.3, 0.01, 0.0, 0.0, -0.35)
# turtlebot3_house: Wall_108's face 0.25 m on the left of the launch pose
AT_HOUSE_WALL = (-2.0, -0.5, 0.01, 0.0, 0.0, 0.35)
HOUSE_SQUARE = ((0.4, 0.0), (0.4, -0.4), (0.0, -0.4), (0.0, 0.0))
# the box rooms: the south wall's face at y = -2.45
AT_ROOM_WALL = (0.0, -2.2, 0.01, 0.0, 0.0, -0.35)
WORLD = TB3 / "worlds" / "turtlebot3_world.world"
HOUSE = TB3 / "worlds" / "turtlebot3_house.world"
# The house's furniture meshes are decomposed as the default has it, from the vendored cache
# entries (HOUSE_DECOMPOSITION, seeded into a copy of the cache: a cold decomposition takes
# about two minutes; test_house_decomposition notices when they go stale); its walls are boxes.
_HOUSE = {"wall_pose": AT_HOUSE_WALL, "wheel": "wheel_left", "square": HOUSE_SQUARE}
CASES = {
    "world-burger": Case(WORLD, BURGER, LAUNCH_POSE, TB3_MODELS, AT_WORLD_WALL),
    "world-waffle": Case(WORLD, WAFFLE, LAUNCH_POSE, TB3_MODELS, AT_WORLD_WALL),
    "house-burger": Case(HOUSE, BURGER, LAUNCH_POSE, TB3_MODELS, **_HOUSE),
    "house-waffle": Case(HOUSE, WAFFLE, LAUNCH_POSE, TB3_MODELS, **_HOUSE),
    "fuel-burger": Case(FUEL_WORLD, BURGER, (0.0, -1.0, 0.01), None, AT_ROOM_WALL, fuel=True),
    "classic-burger": Case(
        CLASSIC_WORLD, BURGER, (0.0, -1.0, 0.01), TB3_MODELS / "turtlebot3_house", AT_ROOM_WALL
    ),
}


@pytest.fixture(scope="module")
def house_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A mesh cache seeded with the house's vendored decomposition (a copy: loads write
    their converted meshes beside it)."""
    cache = tmp_path_factory.mktemp("house-cache")
    for entry in HOUSE_DECOMPOSITION.glob("decompose-*.npz"):
        shutil.copy(entry, cache / entry.name)
    return cache


@pytest.fixture(params=sorted(CASES))
def case(
    request: pytest.FixtureRequest,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    house_cache: Path,
) -> Case:
    """The case with its model path set as its launch sets it; the Fuel world's models in a
    fake Fuel cache (gz's layout; Fuel is never downloaded), the ground plane 40 m wide so
    that its use is visible; the house with its vendored decomposition as the mesh cache."""
    for variable in PATH_VARIABLES:
        monkeypatch.delenv(variable, raising=False)
    chosen = CASES[request.param]
    if chosen.world == HOUSE:
        monkeypatch.setenv("HARNESS_CACHE_DIR", str(house_cache))
    if chosen.model_path is not None:
        monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(chosen.model_path))
    if chosen.fuel:
        cache = tmp_path / "fuel"
        for name, stock in (("ground plane", "ground_plane"), ("sun", "sun")):
            folder = cache / "fuel.gazebosim.org" / "openrobotics" / "models" / name / "3"
            shutil.copytree(STOCK / stock, folder)
        sdf = folder.parent.parent / "ground plane" / "3" / "model.sdf"
        sdf.write_text(sdf.read_text().replace("<size>100 100</size>", "<size>40 40</size>"))
        monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(cache))
    return chosen


def _lidar(run: Run):  # type: ignore[no-untyped-def]
    suite = run.session.core.sensors
    assert suite is not None
    (lidar,) = [s for s in suite.sensors if s.spec.type == "lidar"]
    return lidar


def _robot_bodies(run: Run) -> set[int]:
    model = run.session.model
    return {model.body(name).id for name in run.session.link_names}


@pytest.mark.slow
def test_start_idle_and_first_scan(case: Case, tmp_path: Path) -> None:
    """Only support contacts (wheels, casters on the floor) at the start and while idle,
    <= 1 mm of drift in 10 s, the first /scan within 5 cm of trimesh's ray cast of the
    world's collision triangles for >= 90 % of the rays (median <= 2 cm)."""
    with open_run(
        case.robot,
        case.world,
        case.pose,
        tmp_path / "idle.mcap",
        mesh_collision=case.mesh_collision,
    ) as run:
        scans = run.client.subscribe("/scan", "sensor_msgs/msg/LaserScan")
        first = scans.wait_for_message(sim_timeout=1.0)
        model, data = run.session.model, run.session.sim.data
        start = run.base_qpos()[:3]
        lidar = _lidar(run)
        origin, rotation = lidar.mount.world(data)  # the robot has not moved since the scan
        triangles = world_triangles(model, data, _robot_bodies(run))
        for _ in range(20):  # 10 s, in requests that answer well within 30 s
            run.client.step(round(0.5e9 / run.session.dt_ns))
        drift = float(np.linalg.norm(run.base_qpos()[:3] - start))
    passed, detail = run.verdict()  # closed: every episode has ended
    assert drift <= 1e-3, f"drifted {drift * 1000:.2f} mm in 10 s idle"
    ends = run.robot_ends()
    assert ends, "the robot touches nothing, not even its floor"
    assert all(e.support for e in ends), [(e.body1, e.body2) for e in ends if not e.support]
    assert passed, detail
    assert "support contacts, not judged" in detail
    spec = lidar.options  # the lidar's options record (harness.sensors.LidarOptions)
    angles = np.linspace(spec.min_angle, spec.max_angle, spec.samples)
    expected = ray_cast_ranges(triangles, origin, rotation, angles, spec.range_max)
    measured = np.array(first["ranges"], dtype=float)
    both = np.isfinite(expected) & np.isfinite(measured)
    neither = ~np.isfinite(expected) & ~np.isfinite(measured)
    error = np.abs(measured[both] - expected[both])
    assert np.count_nonzero(both) >= 0.5 * len(angles), "the scan sees too little of the world"
    within = np.count_nonzero(error <= 0.05) + np.count_nonzero(neither)
    assert within >= 0.9 * len(angles), (within, len(angles), np.sort(error)[-5:])
    assert float(np.median(error)) <= 0.02


@pytest.mark.slow
def test_square_back_to_start_replays_without_paths(case: Case, tmp_path: Path) -> None:
    """A 0.4 m square driven through /cmd_vel ends within 10 cm of the start, the default
    verdict passes naming the support contacts, and the recording replays at --level full
    with no model path and no Fuel cache set."""
    record = tmp_path / "square.mcap"
    with open_run(
        case.robot, case.world, case.pose, record, mesh_collision=case.mesh_collision
    ) as run:
        x0, y0, _ = run.base_xy_yaw()
        for dx, dy in case.square:
            run.go_to(x0 + dx, y0 + dy)
        x, y, _ = run.base_xy_yaw()
    passed, detail = run.verdict()  # closed: every episode has ended
    assert math.hypot(x - x0, y - y0) <= 0.10
    assert passed, detail
    env = {k: v for k, v in os.environ.items() if k not in PATH_VARIABLES}
    env["HOME"] = str(tmp_path)  # no ~/.gz/fuel either
    result = subprocess.run(
        [sys.executable, "-m", "harness", "replay", str(record), "--level", "full"],
        env=env, cwd=tmp_path, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    assert "PIPELINE REPRODUCED" in result.stdout


@pytest.mark.slow
def test_a_wheel_driven_into_a_wall_fails_the_default_verdict(case: Case, tmp_path: Path) -> None:
    """Heading 20 degrees into a wall, the wheel on its side (it sticks out of the base)
    touches it first: that contact is no support contact and the default verdict fails."""
    with open_run(
        case.robot,
        case.world,
        case.wall_pose,
        tmp_path / "wall.mcap",
        mesh_collision=case.mesh_collision,
    ) as run:
        for _ in range(16):  # 8 s at 0.1 m/s, in requests that answer well within 30 s
            run.drive(0.1, 0.0, round(0.5e9 / run.session.dt_ns))
    passed, detail = run.verdict()  # closed: every episode has ended
    assert not passed, detail
    hits = [e for e in run.robot_ends() if not e.support]
    first = min(hits, key=lambda e: e.begin_step)
    assert case.wheel in first.body1 + first.body2, [(e.body1, e.body2) for e in hits]
