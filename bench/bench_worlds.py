"""Gazebo worlds as users have them (issue 33), each figure against its own reference in the
same run.

- Load of ``turtlebot3_house`` (turtlebot3_simulations, with the burger at the launch pose)
  with the decomposition cache warm against the same load cold (an empty
  ``$HARNESS_CACHE_DIR``: every non-convex collision mesh decomposed by CoACD); the cold
  load's decomposition time and pieces are in the note. ``--quick``: ``turtlebot3_world``
  (one arena wall) instead.
- Load of a generated arm whose four moving links (``--quick``: two) have concave collision
  meshes (combs of four to seven prongs, made with trimesh) with the cache warm against the
  same load cold, and the cold load with the meshes decomposed in parallel processes against
  one process (``$HARNESS_DECOMPOSE_WORKERS=1``): the entries are the same either way.
- A lockstep session's step rate with the burger's 360-ray lidar (5 Hz) and IMU (200 Hz) in
  the same world (``turtlebot3_house``; ``--quick``: ``turtlebot3_world``), its pieces cached by
  the loads above, against the same robot in an empty world (the floor only), recorded,
  driven by a client in its own process one ``/harness/step`` at a time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

from common import STEP_CLIENT, Row

from harness.models import load_robot
from harness.session import Session

TB3 = Path(__file__).resolve().parents[1] / "tests" / "data" / "worlds" / "turtlebot3"
BURGER = TB3 / "models" / "turtlebot3_burger" / "model.sdf"
LAUNCH_POSE = [-2.0, -0.5, 0.01]


def _load(world: Path, cache: Path) -> tuple[float, int]:
    """Seconds to load the burger in ``world`` with ``cache`` as the mesh cache, and the
    convex pieces the world's meshes became."""
    os.environ["HARNESS_CACHE_DIR"] = str(cache)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(BURGER, pose=LAUNCH_POSE, scene=world)
    seconds = time.perf_counter() - start
    model = robot.model
    pieces = sum("#" in model.geom(g).name for g in range(model.ngeom))
    return seconds, pieces


def _comb(prongs: int) -> Any:
    """A comb of ``prongs`` prongs 6 cm wide, 6 cm apart, 30 cm long (a concave mesh: its
    hull fills the gaps, 3 cm from their floor to the hull's face)."""
    import trimesh

    pitch, depth, thick = 0.06, 0.3, 0.05
    width = pitch * (2 * prongs - 1)
    comb = trimesh.creation.box((width, depth, thick))
    comb.apply_translation((0.0, depth / 2, 0.0))
    for k in range(prongs - 1):
        gap = trimesh.creation.box((pitch, depth, 2 * thick))
        gap.apply_translation((-width / 2 + pitch * (2 * k + 1.5), depth / 2 + 0.15 * depth, 0))
        comb = comb.difference(gap)
    return comb


def _concave_arm(folder: Path, count: int) -> Path:
    """A chain of ``count`` revolute links, each a comb (4, 5, ... prongs)."""
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    links = [f'<link name="base">{inertial}</link>']
    joints = []
    parent = "base"
    for prongs in range(4, 4 + count):
        _comb(prongs).export(folder / f"comb{prongs}.stl")
        links.append(
            f'<link name="comb{prongs}">{inertial}<collision><geometry>'
            f'<mesh filename="comb{prongs}.stl"/></geometry></collision></link>'
        )
        joints.append(
            f'<joint name="j{prongs}" type="revolute"><parent link="{parent}"/>'
            f'<child link="comb{prongs}"/><origin xyz="0 0 {0.5 if parent == "base" else 0.3}"/>'
            '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        )
        parent = f"comb{prongs}"
    path = folder / "combs.urdf"
    path.write_text(f'<robot name="combs">{"".join(links)}{"".join(joints)}</robot>')
    return path


def _arm_load(path: Path, cache: Path, workers: str | None) -> float:
    """Seconds to load ``path`` with ``cache`` as the mesh cache and ``workers`` as
    ``$HARNESS_DECOMPOSE_WORKERS`` (None: unset, every CPU)."""
    from harness.models.build.decompose import WORKERS_VARIABLE

    previous = os.environ.pop(WORKERS_VARIABLE, None)
    if workers is not None:
        os.environ[WORKERS_VARIABLE] = workers
    try:
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_robot(path, cache_dir=cache)
        return time.perf_counter() - start
    finally:
        os.environ.pop(WORKERS_VARIABLE, None)
        if previous is not None:
            os.environ[WORKERS_VARIABLE] = previous


def _robot_rows(quick: bool) -> list[Row]:
    """The arm's cold and cached loads; the full run also decomposes it in one process (its
    combs of 6 and 7 prongs take most of a minute each; ``--quick`` has the 4 and 5 prong
    combs only, about 1.5 s each: less than starting a worker, nothing to compare)."""
    from harness.models.build.decompose import workers_for

    links = 2 if quick else 4
    processes = workers_for(links)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        arm = _concave_arm(folder, links)
        serial = 0.0 if quick else _arm_load(arm, folder / "serial", "1")
        parallel = _arm_load(arm, folder / "parallel", None)
        cached = min(_arm_load(arm, folder / "parallel", None) for _ in range(3))
        same = sorted(p.read_bytes() for p in (folder / "serial").glob("decompose-*.npz")) == (
            sorted(p.read_bytes() for p in (folder / "parallel").glob("decompose-*.npz"))
        )
    rows = [
        Row(
            f"load of an arm with {links} concave link meshes: decomposition cached vs cold",
            cached,
            parallel,
            "s",
            "<= 0.25 of the cold load",
            cached <= 0.25 * parallel,
            higher_is_better=False,
            note=f"cold: {parallel:.1f} s in {processes} processes; cached: best of 3",
        )
    ]
    if not quick:
        rows.append(
            Row(
                f"cold decomposition of the arm's {links} link meshes: {processes} processes "
                "vs one",
                parallel,
                serial,
                "s",
                "<= the serial load, the same cache entries",
                parallel <= serial and same,
                higher_is_better=False,
                note=f"serial {serial:.1f} s, parallel {parallel:.1f} s; entries identical: "
                f"{same} (a worker takes about 3 s to start on the 2-core test machine)",
            )
        )
    return rows


def _lockstep(world: Path | None, steps: int, record: Path) -> float:
    with (
        warnings.catch_warnings(),
        Session(BURGER, world=world, pose=LAUNCH_POSE, record_to=record, mode="velocity") as s,
    ):
        warnings.simplefilter("ignore")
        out = subprocess.run(
            [sys.executable, "-c", STEP_CLIENT, s.url, str(steps)],
            capture_output=True,
            text=True,
            check=True,
        )
    return steps / float(out.stdout.strip())


def run(quick: bool) -> list[Row]:
    os.environ["GZ_SIM_RESOURCE_PATH"] = str(TB3 / "models")
    name = "turtlebot3_world" if quick else "turtlebot3_house"
    world = TB3 / "worlds" / f"{name}.world"
    previous = os.environ.get("HARNESS_CACHE_DIR")
    with tempfile.TemporaryDirectory() as tmp:
        try:
            cold, pieces = _load(world, Path(tmp) / "cold")
            warm = min(_load(world, Path(tmp) / "cold")[0] for _ in range(3))
            rows = [
                Row(
                    f"load of {name} with the burger: decomposition cached vs cold",
                    warm,
                    cold,
                    "s",
                    "<= 0.25 of the cold load",
                    warm <= 0.25 * cold,
                    higher_is_better=False,
                    note=f"cold: {cold:.1f} s, CoACD included, {pieces} convex pieces; cached: "
                    "best of 3",
                )
            ]
            # the lidar row runs in the same world, its pieces cached by the loads above
            steps = 1_000 if quick else 5_000
            empty = in_world = 0.0
            for i in range(2 if quick else 3):  # interleaved, best of each: the machine is shared
                empty = max(empty, _lockstep(None, steps, Path(tmp) / f"empty{i}.mcap"))
                in_world = max(in_world, _lockstep(world, steps, Path(tmp) / f"w{i}.mcap"))
        finally:
            if previous is None:
                os.environ.pop("HARNESS_CACHE_DIR", None)
            else:
                os.environ["HARNESS_CACHE_DIR"] = previous
    rows.extend(_robot_rows(quick))
    rows.append(
        Row(
            f"lockstep burger with its 360-ray lidar in {name} vs an empty world",
            in_world,
            empty,
            "steps/s",
            ">= 0.7 of the empty world",
            in_world >= 0.7 * empty,
            note="recorded, one /harness/step per step; the world at its max_step_size 1 ms, "
            "the empty world at the default 2 ms",
        )
    )
    return rows
