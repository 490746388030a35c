"""A fork edit of an object's pose: the crate lifted at the fork falls from higher up; the
run up to the fork is the parent's, the move is recorded as an epoch (reason ``pose``) after
a ``set_body_pose`` marker, and the child replays on its own at both levels."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import pytest

from harness import Session
from harness.cli import main
from harness.models import RobotSpec, WorldObject
from harness.recording import Recording

from .conftest import states

FORK, STEPS = 100, 300
CRATE = WorldObject("crate", "box", (0.03, 0.03, 0.03), pose=(0.5, 0.3, 0.6), mass=0.2)


@pytest.fixture(scope="module")
def crate_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("pose") / "crate.mcap"
    arm = RobotSpec("demo", namespace="")
    with Session(robots=[arm], scene="table", objects=[CRATE], record_to=path) as session:
        session.step(STEPS)
    return path


def _crate_z(session: Session) -> float:
    model = session.model
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "crate")
    return float(session.call(lambda: session.sim.data.xpos[body][2]))


def test_an_object_moved_at_the_fork(crate_run: Path, tmp_path: Path) -> None:
    child = tmp_path / "lifted.mcap"
    with Session.resume(
        crate_run, step=FORK, record_to=child, edits=["pose.crate=0.5,0.3,1.5"]
    ) as session:
        assert _crate_z(session) == pytest.approx(1.5)
        session.step(STEPS - FORK)
    parent, lifted = states(crate_run), states(child)
    assert {k: v for k, v in lifted.items() if k <= FORK} == {
        k: v for k, v in parent.items() if k <= FORK
    }
    assert all(lifted[k] != parent[k] for k in range(FORK + 1, STEPS + 1))
    with Recording(child) as rec:
        (epoch,) = rec.epochs()
        (marker,) = [f for f in rec.bridge_frames(FORK) if f.topic == "harness/python"]
    assert (epoch.step, epoch.reason) == (FORK, "pose")
    assert json.loads(marker.text)["call"] == "set_body_pose"
    assert main(["replay", str(child)]) == 0
    assert main(["replay", str(child), "--level", "full"]) == 0


def test_only_a_free_body_moves(crate_run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["serve", "--port", "0", "--from", str(crate_run), "--at", str(FORK), "--set"]
    assert main([*args, "pose.link3=0,0,1"]) == 2
    err = capsys.readouterr().err
    assert "body 'link3': no free body of that name" in err
    assert err.count("\n") == 1
