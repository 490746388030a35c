"""The clearance logger (``mj_geomDistance``) on a real Session: the margin ``harness explore``
drives toward a collision, measured without changing the recording."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.events import ClearanceLogger, LoggerConfigError
from harness.scenario import IterationSpec, Scenario
from harness.scenario.session_runner import SessionIterationRunner, robot_links
from tests.explore.conftest import write_variant


def _clearance(tmp_path: Path, position: list[float], name: str) -> tuple[ClearanceLogger, object]:
    path = write_variant(
        tmp_path,
        f"{name}.yaml",
        "sweep.yaml",
        {
            "objects": [
                {"name": "obstacle", "shape": "sphere", "size": [0.03], "position": position}
            ],
            "explore": None,
        },
    )
    scenario = Scenario.load(path)
    made: list[ClearanceLogger] = []

    def watcher(session):
        logger = ClearanceLogger(
            session.model,
            robot_bodies=robot_links(session.world),
            ignore=[("*", "box"), ("*", "table"), ("*", "floor")],
        )
        made.append(logger)
        return logger

    out = tmp_path / name
    spec = IterationSpec(
        name, 1, scenario, None, 1.5, 0, "127.0.0.1", 0, out, out / "recording.mcap"
    )
    result = SessionIterationRunner(watchers=(watcher,))(spec)
    return made[0], result


def test_clearance_shrinks_as_the_obstacle_nears_the_sweep(tmp_path: Path) -> None:
    far, _ = _clearance(tmp_path, [0.80, 0.0, 0.5], "far")
    near, _ = _clearance(tmp_path, [0.72, 0.0, 0.5], "near")
    hit, result = _clearance(tmp_path, [0.6, 0.0, 0.5], "hit")
    assert far.minimum.other_geom == near.minimum.other_geom == "obstacle"
    assert far.minimum.robot_body in {"hand", "left_finger", "right_finger", "link7"}
    assert 0 < near.minimum.distance < far.minimum.distance < 0.3
    # an obstacle in the sweep: the clearance reaches contact and the run fails on it
    assert hit.minimum.distance <= 1e-3
    assert not result.passed
    assert "obstacle" in (result.reason or "")


def test_resting_pairs_are_not_a_margin(tmp_path: Path) -> None:
    """The base rests on the floor from the start (clearance 0): that pair is left out, so
    the margin is how close the swept hand comes to the table top, not zero."""
    path = write_variant(tmp_path, "s.yaml", "sweep.yaml", {"explore": None, "objects": None})
    scenario = Scenario.load(path)
    made: list[ClearanceLogger] = []

    def watcher(session):
        made.append(
            ClearanceLogger(
                session.model, robot_bodies=robot_links(session.world), ignore=[("*", "box")]
            )
        )
        return made[-1]

    out = tmp_path / "out"
    spec = IterationSpec("s", 1, scenario, None, 1.5, 0, "127.0.0.1", 0, out, out / "r.mcap")
    SessionIterationRunner(watchers=(watcher,))(spec)
    # the arm stands on the floor beside the table: link0 rests on the floor (left out);
    # link1 is 0.143 m above it, the swept hand passes over the table top
    assert made[0].minimum.robot_body != "link0"
    assert made[0].minimum.other_geom in {"floor", "table_top"}
    assert 0.005 < made[0].minimum.distance <= 0.1431


def test_clearance_emits_no_events_and_keeps_the_recording(tmp_path: Path) -> None:
    path = write_variant(tmp_path, "s.yaml", "sweep.yaml", {"explore": None})
    scenario = Scenario.load(path)
    runs = []
    for name, watchers in (("plain", ()), ("watched", (_watch,))):
        out = tmp_path / name
        spec = IterationSpec(
            name, 1, scenario, None, 1.5, 0, "127.0.0.1", 0, out, out / "recording.mcap"
        )
        runs.append(SessionIterationRunner(watchers=watchers)(spec))
    assert runs[0].recording.read_bytes() == runs[1].recording.read_bytes()


def _watch(session):
    return ClearanceLogger(session.model, robot_bodies=robot_links(session.world))


def test_clearance_bad_options_are_one_line(tmp_path: Path) -> None:
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='b'><geom size='.1'/></body></worldbody></mujoco>"
    )
    with pytest.raises(LoggerConfigError, match="robot_bodies\\[0\\]: no body named 'nope'"):
        ClearanceLogger(model, robot_bodies=["nope"])
    with pytest.raises(LoggerConfigError, match="distmax must be > 0"):
        ClearanceLogger(model, robot_bodies=["b"], distmax=0)
    with pytest.raises(LoggerConfigError, match="needs at least one robot body"):
        ClearanceLogger(model, robot_bodies=[])
