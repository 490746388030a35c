"""``harness replay --actuation kinematic|servo`` on a recorded mobile base run: the /cmd_vel
stream re-run with the planar base (kinematic) or the wheeled diff drive (dynamic)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from harness import Session
from harness.cli import main
from harness.models.mobile import MOBILE_CONTROLLERS, load_mobile_bot
from harness.replay.base_resim import resimulate_base
from harness.replay.errors import LevelUnavailableError
from harness.testing import connect

TWIST = "geometry_msgs/msg/Twist"


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {
        "linear": {"x": linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": angular},
    }


def _record(path: Path, controllers: Any = MOBILE_CONTROLLERS) -> None:
    session = Session(load_mobile_bot(), controllers=controllers, record_to=path)
    with session, connect(session.url) as client:
        client.step(20)
        for linear, angular, n in ((0.2, 0.0, 20), (0.0, 1.0, 16), (0.2, 0.0, 10), (0.0, 0.0, 6)):
            for _ in range(n):
                client.publish("/cmd_vel", TWIST, _twist(linear, angular))
                client.step(25)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("base") / "drive.mcap"
    _record(path)
    return path


@pytest.mark.slow
def test_replay_mode_kinematic_reports_the_path_difference(recorded: Path, tmp_path: Path) -> None:
    report_path = tmp_path / "report.json"
    code = main(["replay", str(recorded), "--actuation", "kinematic", "--report", str(report_path)])
    assert code == 0
    report = json.loads(report_path.read_text())
    assert report["recorded_controller"] == "diff_drive_controller/DiffDriveController"
    assert report["commands"] == 52
    assert report["steps_compared"] >= 52 * 25
    # 0.2 m/s for 1 s and 0.5 s: 0.3 m on both paths
    assert report["recorded_path_length"] == pytest.approx(0.3, abs=0.02)
    assert report["resimulated_path_length"] == pytest.approx(0.3, abs=0.005)
    # the planar base follows the command exactly, the wheels lag: a small, non-zero difference
    assert 0.0 < report["max_path_deviation"] < 0.02
    assert report["final_position_error"] <= report["max_path_deviation"]
    assert report["final_heading_error"] < math.radians(3)
    # wheel slip: the recorded wheels roll the whole way; the planar base slides them along
    assert report["recorded_encoder_distance"] == pytest.approx(0.3, abs=0.01)
    assert report["resimulated_encoder_distance"] < 0.05
    assert report["collisions_appearing"] == report["collisions_disappearing"] == []


@pytest.mark.slow
def test_replay_mode_dynamic_re_runs_the_wheels_the_same(recorded: Path) -> None:
    report = resimulate_base(recorded, "servo")
    assert report.steps_compared >= 52 * 25
    assert report.max_path_deviation == 0.0  # the recorded controller, the same commands
    assert report.recorded_encoder_distance == report.resimulated_encoder_distance
    assert "wheel slip (re-run)" in report.format()
    # a threshold on the path deviation sets the exit code
    assert (
        main(["replay", str(recorded), "--actuation", "kinematic", "--max-tracking-error", "1e-9"])
        == 1
    )


@pytest.mark.slow
def test_a_planar_recording_has_no_wheels_for_the_dynamic_mode(tmp_path: Path) -> None:
    from tests.mobile.test_planar import PLANAR_YAML

    path = tmp_path / "planar.mcap"
    yaml = tmp_path / "planar.yaml"
    yaml.write_text(PLANAR_YAML)
    _record(path, yaml)
    with pytest.raises(
        LevelUnavailableError, match="planar base: --actuation servo needs a diff drive"
    ):
        resimulate_base(path, "servo")
    kinematic = resimulate_base(path, "kinematic")
    assert kinematic.max_path_deviation == 0.0


def test_contact_pairs_name_a_wall_the_base_reaches() -> None:
    import warnings

    import numpy as np

    from harness.replay.base_checks import contact_pairs, robot_bodies

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the base is set down onto the floor: a note
        robot = load_mobile_bot(pose=[1.4, 0.0, 0.0])
    model = robot.model
    free = next(j for j in range(model.njnt) if model.jnt_type[j] == 0)
    adr = int(model.jnt_qposadr[free])
    away = np.array([model.qpos0], dtype=float)  # the loaded pose: x = 1.4, on the floor
    into = away.copy()
    into[0, adr] = 2.0 - 0.09 + 0.01  # the chassis front 1 cm into the east wall (x = 2.0)
    bodies = robot_bodies(model, model.joint(free).name)
    assert contact_pairs(model, away, bodies) == set()
    hits = contact_pairs(model, np.vstack([away, into]), bodies)
    assert ("base_link", "room::east_wall") in hits
    assert {other for _, other in hits} == {"room::east_wall"}
