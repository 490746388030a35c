"""The meshes a URDF references travel with the recording: a rebuild from the source
attachments works where the robot's package is gone (another machine)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from harness.models import load_robot
from harness.recording import PhysicsState, Recorder, Recording, describe_run
from harness.replay.source import rebuild_robot

DATA = Path(__file__).resolve().parents[1] / "data" / "models" / "pkg_demo"


def test_meshes_are_attached_and_a_rebuild_elsewhere_finds_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    pkg = tmp_path / "ws" / "src" / "pkg_demo"
    shutil.copytree(DATA, pkg)
    template = (pkg / "urdf" / "meshy.urdf").read_text()
    urdf = pkg / "urdf" / "robot.urdf"
    # One mesh through package:// (package.xml name renamed_pkg), one relative to the file.
    urdf.write_text(template.replace("PKG", "renamed_pkg").replace("MESH", "../meshes/tetra.stl"))
    robot = load_robot(urdf, control="position")
    description = describe_run(robot)
    mesh = (pkg / "meshes" / "tetra.stl").read_bytes()
    assert description.attachments["source/renamed_pkg/meshes/tetra.stl"] == mesh
    # the same bytes under the relative spelling: attached once, the name laid out from it
    assert [b for b in description.attachments.values() if b == mesh] == [mesh]
    links = json.loads(description.attachments["source-links.json"])
    assert links == {"meshes/tetra.stl": "renamed_pkg/meshes/tetra.stl"}
    path = tmp_path / "meshy.mcap"
    with Recorder(path, metadata=description.metadata, attachments=description.attachments) as rec:
        rec.write_physics_state(
            PhysicsState(step=0, sim_time_ns=0, state_spec=1, state=[0.0], qpos=[0.0], qvel=[0.0])
        )
    shutil.rmtree(tmp_path / "ws")  # the package is gone, as on another machine
    with Recording(path) as rec:
        rebuilt = rebuild_robot(rec)
    assert rebuilt.sha256 == robot.sha256
    assert np.array_equal(rebuilt.model.mesh_vert, robot.model.mesh_vert)


def test_play_serves_the_meshes_the_description_references(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import asyncio
    import json
    import re
    import urllib.request

    from websockets.asyncio.client import connect

    from harness.replay.play import Player
    from harness.session import Session

    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    pkg = tmp_path / "ws" / "src" / "pkg_demo"
    shutil.copytree(DATA, pkg)
    urdf = pkg / "urdf" / "robot.urdf"
    urdf.write_text(
        (pkg / "urdf" / "meshy.urdf")
        .read_text()
        .replace("PKG", "renamed_pkg")
        .replace("MESH", "../meshes/tetra.stl")
    )
    mesh = (pkg / "meshes" / "tetra.stl").read_bytes()
    path = tmp_path / "meshy.mcap"
    with Session(urdf, record_to=path) as session:
        session.step(5)
    shutil.rmtree(tmp_path / "ws")  # another machine: no package
    with Recording(path) as rec:
        (recorded,) = list(rec.messages("/robot_description", decode=True))
    assert "package://renamed_pkg/meshes/tetra.stl" in recorded.msg.data  # kept as published

    async def description() -> str:
        player = Player(path, start="paused")
        url = await player.start()
        try:
            player.advance_to(player.last_step)
            async with connect(url) as ws:
                await ws.send(json.dumps({"op": "subscribe", "topic": "/robot_description"}))
                while True:
                    frame = json.loads(await asyncio.wait_for(ws.recv(), 10))
                    if frame.get("op") == "publish":
                        text: str = frame["msg"]["data"]
                        urls = re.findall(r'filename="(http://127\.0\.0\.1:\d+/[^"]+)"', text)
                        assert len(urls) == 2
                        for u in urls:  # fetched while the player runs
                            with urllib.request.urlopen(u, timeout=10) as answer:
                                assert answer.read() == mesh
                                assert answer.headers["Access-Control-Allow-Origin"] == "*"
                        return text
        finally:
            await player.stop()

    played = asyncio.run(description())
    assert 'filename="package://' not in played
