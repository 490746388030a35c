"""Goldens that fit a code review (issue 35, "Small goldens"): the Panda of the real
franka_description in tests/data (fr3 with its hand) and the Panda of moveit_resources
(tests/data/descriptions/moveit_resources_panda_description), 3 s in lockstep with the
physics state of every step, checked for size; a golden that refers to its project's files by
content hash, resolved only by the pytest golden check."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import trimesh.proximity
import trimesh.ray.ray_triangle  # noqa: F401  (robots' link meshes are measured: native modules)

# Imported before the inner runs (pytester restores sys.modules after each in-process run;
# the controller registry must not see its modules imported twice).
import harness.plugin.golden_sources  # noqa: F401
from harness.controllers.registry import known_types
from harness.recording import Recording

known_types()  # every controller module imported once, here

FRANKA = Path(__file__).resolve().parents[1] / "data" / "descriptions" / "franka_description"
MEGABYTE = 1_000_000

PANDA = """
import pathlib
import pytest

ROBOT = str(pathlib.Path(__file__).parent / "franka_description/robots/fr3/fr3.urdf.xacro")

@pytest.mark.harness(robot=ROBOT, robot_args={"hand": "true"})
def test_arm(harness_session, golden):
    harness_session.step(round(3.0 / harness_session.sim.model.opt.timestep))
    golden.check(joint_position=1e-6)
"""


def _harness(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "harness", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.slow
def test_the_panda_golden_fits_and_a_project_golden_is_read_only_by_its_check(pytester, run):
    shutil.copytree(FRANKA, pytester.path / "franka_description")
    pytester.makepyfile(test_panda=PANDA)
    golden = pytester.path / "recordings" / "test_panda" / "test_arm.mcap"

    run("--harness-update-goldens").assert_outcomes(passed=1)
    carried = golden.stat().st_size
    with Recording(golden) as rec:
        names = rec.attachment_names
        assert rec.last_step == 1500
        assert len(list(rec.physics_states())) == 1501  # the state of every step, as today
    assert "model.mjb" not in names  # the carried sources rebuild to the recorded model
    assert any(n.startswith("source/package/franka_description/meshes/") for n in names)
    assert carried <= MEGABYTE, carried
    run().assert_outcomes(passed=1)
    assert _harness("replay", golden).returncode == 0  # a carried golden replays anywhere

    run("--harness-update-goldens", "--harness-golden-sources=project").assert_outcomes(passed=1)
    referring = golden.stat().st_size
    with Recording(golden) as rec:
        names = rec.attachment_names
    assert "source-refs.json" in names
    assert not any(n.startswith(("source/package/", "source/xacro/")) for n in names), names
    assert referring < carried
    run().assert_outcomes(passed=1)

    # outside the golden check: one line each, nothing rebuilt
    for args in (["replay", golden], ["diff", golden, golden], ["inspect", golden]):
        done = _harness(*args)
        assert done.returncode != 0, args
        assert "Traceback" not in done.stderr
        [line] = done.stderr.strip().splitlines()
        assert "refers to its sources in its project by content hash" in line, line

    # a changed source: the check fails with one line naming it
    link2 = "franka_description/meshes/robot_arms/fr3/collision/link2.stl"
    with Recording(golden) as rec:
        refs = json.loads(rec.attachment("source-refs.json"))
    assert refs[f"package/{link2}"]["path"] == link2  # the file of that name, of equal files
    mesh = pytester.path / link2
    blob = mesh.read_bytes()
    mesh.write_bytes(b"edited" + blob[6:])  # the binary STL header: the same mesh
    changed = run()
    changed.assert_outcomes(failed=1)
    changed.stdout.fnmatch_lines(
        [
            "*test_arm.mcap: its source franka_description/meshes/robot_arms/fr3/collision/"
            "link2.stl changed since the golden was written*--harness-update-goldens*"
        ]
    )


MOVEIT_PANDA = FRANKA.parent / "moveit_resources_panda_description"

PANDA_URDF = """
import pathlib
import pytest

ROBOT = str(pathlib.Path(__file__).parent / "{package}/urdf/panda.urdf")

@pytest.mark.harness(robot=ROBOT)
def test_arm(harness_session, golden):
    harness_session.step(round(3.0 / harness_session.sim.model.opt.timestep))
    golden.check(joint_position=1e-6)
"""


@pytest.mark.slow
def test_the_moveit_resources_panda_golden_carries_each_collision_mesh_once(pytester, run):
    """The issue's own target: the Panda of moveit_resources (tests/data, from its xacro
    package), 3 s with every step's state, is <= 1 MB carrying its sources (11,655,353 B at
    2fffa9d, with model.mjb and the visual DAEs; 498,367 B now); its 10.5 MB of visual DAEs
    are not attached (no visuals asked, no camera)."""
    package = MOVEIT_PANDA.name
    shutil.copytree(MOVEIT_PANDA, pytester.path / package)
    pytester.makepyfile(test_panda=PANDA_URDF.format(package=package))
    golden = pytester.path / "recordings" / "test_panda" / "test_arm.mcap"

    run("--harness-update-goldens").assert_outcomes(passed=1)
    size = golden.stat().st_size
    with Recording(golden) as rec:
        names = rec.attachment_names
        blobs = [rec.attachment(n) for n in names]
        assert rec.last_step == 1500
        assert len(list(rec.physics_states())) == 1501  # the state of every step
        assert rec.metadata.get("visuals") is None
    assert "model.mjb" not in names  # the carried sources rebuild to the recorded model
    meshes = sorted(n for n in names if n.startswith(f"source/{package}/meshes/"))
    stls = sorted(p.name for p in (MOVEIT_PANDA / "meshes" / "collision").glob("*.stl"))
    carried = {n.rsplit("/", 1)[1] for n in meshes}
    assert not any(n.endswith(".dae") for n in names), meshes  # visual-only: not asked
    assert carried == set(stls), meshes  # every collision mesh, each once
    assert len({bytes(b) for b in blobs}) == len(blobs), "an attachment is carried twice"
    assert size <= MEGABYTE, size
    run().assert_outcomes(passed=1)
    assert _harness("replay", golden).returncode == 0
