"""The mobile-base re-run of ``harness replay --actuation`` drives the session core, not a live
session: it runs with socket creation and thread starts refused (issue 32, "the core is the
one engine"). The recording itself is made by a live session and a real client."""

from __future__ import annotations

import socket
import threading
from pathlib import Path
from typing import Any, NoReturn

import pytest

from harness import Session
from harness.cli import main
from harness.models.mobile import MOBILE_CONTROLLERS, load_mobile_bot
from harness.replay.base_resim import resimulate_base
from harness.testing import connect

TWIST = "geometry_msgs/msg/Twist"
DRIVE = ((0.2, 0.0, 8), (0.0, 1.0, 6), (0.2, 0.0, 4))
"""(linear m/s, angular rad/s, commands), one command every 25 steps."""


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {
        "linear": {"x": linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": angular},
    }


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A diff drive run recorded live: 20 idle steps, then the commands of :data:`DRIVE`."""
    path = tmp_path_factory.mktemp("base-core") / "drive.mcap"
    with pytest.warns(UserWarning, match="floating base lifted"):
        robot = load_mobile_bot()
    session = Session(robot, controllers=MOBILE_CONTROLLERS, record_to=path)
    with session, connect(session.url) as client:
        client.step(20)
        for linear, angular, n in DRIVE:
            for _ in range(n):
                client.publish("/cmd_vel", TWIST, _twist(linear, angular))
                client.step(25)
    return path


@pytest.fixture
def no_io(monkeypatch: pytest.MonkeyPatch) -> None:
    """Refuse every socket (asyncio's self-pipe included) and every thread start."""

    class NoSocket(socket.socket):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            raise AssertionError("a socket was created during the base re-run")

    def no_thread(self: threading.Thread) -> NoReturn:
        raise AssertionError(f"thread {self.name!r} was started during the base re-run")

    monkeypatch.setattr(socket, "socket", NoSocket)
    monkeypatch.setattr(threading.Thread, "start", no_thread)


@pytest.mark.filterwarnings("ignore:.*floating base lifted")
def test_the_base_re_run_drives_the_core_without_sockets_or_threads(
    drive: Path, no_io: None
) -> None:
    commands = sum(n for _, _, n in DRIVE)
    last = 20 + 25 * commands
    servo = resimulate_base(drive, "servo")
    # the recorded controller and commands through the core: the recorded path, bit for bit
    assert servo.commands == commands
    assert servo.steps_compared == last + 1  # every state, step 0 to the last
    assert servo.max_path_deviation == 0.0
    assert servo.final_heading_error == 0.0
    assert servo.recorded_encoder_distance == servo.resimulated_encoder_distance
    kinematic = resimulate_base(drive, "kinematic")
    assert kinematic.steps_compared == last + 1
    assert 0.0 < kinematic.max_path_deviation < 0.01  # the planar base does not lag
    # both bases drive the same commands: the same distance within a few millimetres
    assert kinematic.resimulated_path_length == pytest.approx(servo.recorded_path_length, abs=0.003)
    assert kinematic.recorded_path_length == servo.recorded_path_length


@pytest.mark.filterwarnings("ignore:.*floating base lifted")
def test_the_cli_base_re_run_needs_no_socket(
    drive: Path, no_io: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", str(drive), "--actuation", "kinematic"]) == 0
    out = capsys.readouterr().out
    assert f"base re-run (kinematic) of {sum(n for _, _, n in DRIVE)} commands on /cmd_vel" in out
