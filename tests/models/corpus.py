"""The example-robot-data corpus as the tests and the README table see it.

``python -m tests.models.corpus`` prints the README's corpus table (every URDF loaded, held
for 10 s under gravity, the legged ones stood for 5 s as floating robots), from one run.
"""

from __future__ import annotations

import statistics
import tempfile
import warnings
from pathlib import Path
from typing import NamedTuple

from tests.models.paths import robots_dir

HERE = Path(__file__).resolve().parent

# A URDF that does not load, and the one reason (the test checks the message).
EXPECTED_LOAD_FAILURES = {
    # an empty xacro stub: nothing to load
    "ur_description/urdf/ur3.urdf": "<robot> has no <link>",
}

# Fixed-base robots that cannot hold their initial configuration, and why. Each is checked:
# the reason check-model gives must be this one. These files give a joint an effort limit
# below the gravity torque it carries at the zero configuration (the real PR2 and Baxter
# shoulders carry their arms on counterbalance springs the URDF does not describe). Baxter's
# file declares <transmission>s for its grippers only: its arm joints are passive (no servo to
# hold; harness.models.build.passive), so it is not listed.
EXPECTED_HOLD_FAILURES = {
    "pr2_description/urdf/pr2.urdf": "below the gravity load",
    "romeo_description/urdf/romeo_laas_small.urdf": "below the gravity load",
    "simple_humanoid_description/urdf/simple_humanoid.urdf": "below the gravity load",
    "simple_humanoid_description/urdf/simple_humanoid_classical.urdf": "below the gravity load",
}

# Legged robots stood on the floor as floating robots for 5 s.
FLOATING = (
    "a1_description/urdf/a1.urdf",
    "anymal_b_simple_description/robots/anymal.urdf",
    "anymal_c_simple_description/urdf/anymal.urdf",
    "b1_description/urdf/b1.urdf",
    "bolt_description/robots/bolt.urdf",
    "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "go1_description/urdf/go1.urdf",
    "go2_description/urdf/go2.urdf",
    "hyq_description/robots/hyq_no_sensors.urdf",
    "icub_description/robots/icub_reduced.urdf",
    "laikago_description/urdf/laikago.urdf",
    "quadruped_description/urdf/quadruped.urdf",
    "romeo_description/urdf/romeo_small.urdf",
    "solo_description/robots/solo.urdf",
    "solo_description/robots/solo12.urdf",
    "talos_data/robots/talos_reduced.urdf",
)


GAZEBO = HERE.parent / "data" / "gazebo_models"
GAZEBO_MODELS = ("simple_arm", "double_pendulum_with_base", "pioneer3at", "simple_gripper")
"""Robots of osrf/gazebo_models (SDF): held as fixed robots, stood as they are (free)."""


class Row(NamedTuple):
    corpus: str
    robots: int
    loaded: int
    held: int
    stood: str
    median_hold: float
    worst_hold: float


def _table(rows: list[Row]) -> str:
    lines = [
        "| corpus | robots | loaded | held (1 mrad, 10 s) | stood (5 s) | median hold error "
        "| worst hold error |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r.corpus} | {r.robots} | {r.loaded} | {r.held} | {r.stood} | "
            f"{r.median_hold:.2g} rad | {r.worst_hold:.2g} rad |"
        )
    return "\n".join(lines)


def run_corpus(cache: Path) -> list[Row]:
    """Load, hold and stand every robot (the numbers of the README table)."""
    from harness.errors import HarnessError
    from harness.models import load_robot
    from harness.models.check.report import check_loaded
    from harness.models.errors import ModelWarning

    root = robots_dir()
    urdfs = sorted(root.rglob("*.urdf"))
    loaded = held = 0
    errors: list[float] = []
    for path in urdfs:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelWarning)
                robot = load_robot(path, cache_dir=cache, mesh_collision="hull")
        except HarnessError:
            continue
        loaded += 1
        report = check_loaded(robot, str(path), step_response=False, kinematic=False)
        errors.append(report.worst_hold)
        held += all(j.holds for j in report.joints)
    stood = 0
    for relative in FLOATING:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            robot = load_robot(
                root / relative, cache_dir=cache, base="floating", mesh_collision="hull"
            )
        report = check_loaded(
            robot, relative, hold_seconds=0.002, step_response=False, kinematic=False
        )
        stood += bool(report.stand and report.stand.stood)
    sdf_loaded = sdf_held = sdf_stood = 0
    sdf_errors: list[float] = []
    for name in GAZEBO_MODELS:
        path = GAZEBO / name / "model.sdf"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            fixed = load_robot(path, cache_dir=cache, base="fixed", mesh_collision="hull")
            free = load_robot(path, cache_dir=cache, mesh_collision="hull")
        sdf_loaded += 1
        report = check_loaded(fixed, name, step_response=False, kinematic=False)
        sdf_errors.append(report.worst_hold)
        sdf_held += all(j.holds for j in report.joints)
        report = check_loaded(free, name, hold_seconds=0.002, step_response=False, kinematic=False)
        sdf_stood += bool(report.stand and report.stand.stood)
    return [
        Row(
            "osrf/gazebo_models (SDF)",
            len(GAZEBO_MODELS),
            sdf_loaded,
            sdf_held,
            f"{sdf_stood} of {len(GAZEBO_MODELS)}",
            statistics.median(sdf_errors),
            max(sdf_errors),
        ),
        Row(
            "example-robot-data 6.0.0 (URDF)",
            len(urdfs),
            loaded,
            held,
            f"{stood} of {len(FLOATING)}",
            statistics.median(errors),
            max(errors),
        ),
    ]


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as folder:
        print(_table(run_corpus(Path(folder))))
