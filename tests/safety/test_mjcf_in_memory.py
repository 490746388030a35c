"""A model rebuilt from a recording compiles through MuJoCo's virtual file system (issue 31):
MuJoCo's C code is given strings and bytes, never a path, so it cannot open a file either.

The recording is an MJCF robot made by the project's recorder (``Session``) whose model
``<include>``s a file that names a mesh through ``<compiler meshdir>``; the include and the
mesh are attached beside it (rewritten with the mcap library). While MuJoCo parses or
compiles, every folder under the temporary directory (the private rebuild folder) is moved
away: a MuJoCo that opened its files by path would not find them. The rebuilt model must still
be the recorded one (its MJCF SHA-256 equals ``model_sha256``).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import mujoco
import pytest

from harness.recording import Recording
from harness.replay.errors import UnsafeRecordingError
from harness.replay.source import rebuild_robot, resolve_model
from harness.session import Session
from tests.replay import mcap_edit

ROBOT = """<mujoco model="arm">
  <compiler meshdir="meshes" angle="radian"/>
  <include file="inc/assets.xml"/>
  <worldbody>
    <body name="link1" pos="0 0 0.1">
      <joint name="joint1" type="hinge" axis="0 0 1"/>
      <geom type="mesh" mesh="box" mass="1"/>
      <body name="link2" pos="0 0 0.3">
        <joint name="joint2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" size="0.03 0.1" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
INCLUDE = '<mujoco><asset><mesh name="box" file="box.stl" scale="0.1 0.1 0.1"/></asset></mujoco>'


def _box_stl() -> bytes:
    """A binary STL of a unit cube (12 triangles)."""
    import struct

    corners = [(x, y, z) for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)]
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    out = bytearray(b"\0" * 80 + struct.pack("<I", len(faces)))
    for face in faces:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for index in face:
            out += struct.pack("<3f", *corners[index])
        out += b"\0\0"
    return bytes(out)


@pytest.fixture(scope="module")
def robot_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The robot's files (name under ``source/model/`` -> bytes)."""
    return {
        "arm.xml": ROBOT.encode(),
        "inc/assets.xml": INCLUDE.encode(),
        "meshes/box.stl": _box_stl(),
    }


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory, robot_files: dict[str, bytes]) -> Path:
    """A recording of the MJCF robot made by the recorder."""
    folder = tmp_path_factory.mktemp("mjcf-robot")
    for name, blob in robot_files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(blob)
    path = folder / "arm.mcap"
    with Session(str(folder / "arm.xml"), record_to=path) as live:
        live.set_positions({"joint1": 0.3})
        live.step(5)
    return path


def _rewrite(src: Path, dst: Path, edit: Callable[[dict[str, bytes]], dict[str, bytes]]) -> Path:
    mcap_edit.rewrite(src, dst, attachments=edit)
    return dst


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A temporary directory of this test's own: the rebuild folder is made in it."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


@pytest.fixture
def mujoco_without_folders(private_tmp: Path, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """While MuJoCo parses or compiles, every folder of ``private_tmp`` is moved away (and
    back after); the names of the MuJoCo functions called are returned."""
    calls: list[str] = []
    hidden = private_tmp.parent / "hidden"
    hidden.mkdir()

    def away() -> Iterator[tuple[Path, Path]]:
        for folder in list(private_tmp.iterdir()):
            moved = hidden / folder.name
            folder.rename(moved)
            yield folder, moved

    def wrap(name: str, function: Callable[..., Any]) -> Callable[..., Any]:
        def hiding(*args: Any, **kwargs: Any) -> Any:
            calls.append(name)
            moved = list(away())
            try:
                return function(*args, **kwargs)
            finally:
                for folder, where in moved:
                    where.rename(folder)

        return hiding

    for name in ("from_file", "from_string"):
        monkeypatch.setattr(
            mujoco.MjSpec, name, staticmethod(wrap(name, getattr(mujoco.MjSpec, name)))
        )
    monkeypatch.setattr(mujoco.MjSpec, "compile", wrap("compile", mujoco.MjSpec.compile))
    for name in ("from_xml_path", "from_xml_string"):
        monkeypatch.setattr(
            mujoco.MjModel, name, staticmethod(wrap(name, getattr(mujoco.MjModel, name)))
        )
    return calls


def test_an_mjcf_robot_rebuilds_with_its_folder_gone_while_mujoco_runs(
    recorded: Path, robot_files: dict[str, bytes], tmp_path: Path, mujoco_without_folders: list[str]
) -> None:
    """The MJCF source, its include and its mesh reach MuJoCo as a string and assets: the
    rebuild works with the rebuild folder absent whenever MuJoCo runs, and gives the recorded
    model (on main MuJoCo parsed the file from the folder: "Error opening file")."""

    def attach(attachments: dict[str, bytes]) -> dict[str, bytes]:
        kept = {n: b for n, b in attachments.items() if n != "model.mjb"}
        kept.update({f"source/model/{n}": b for n, b in robot_files.items()})
        return kept

    path = _rewrite(recorded, tmp_path / "sources.mcap", attach)
    with Recording(path) as rec:
        robot = rebuild_robot(rec)
        assert robot.sha256 == rec.metadata["model_sha256"]
        model, where = resolve_model(rec)
    assert where.startswith("source attachments (rebuilt; MJCF SHA-256 matches)")
    assert model.nmesh == 1
    assert "from_string" in mujoco_without_folders
    assert "from_file" not in mujoco_without_folders
    assert "from_xml_path" not in mujoco_without_folders


def test_the_attached_mjcf_text_compiles_with_its_folder_gone(
    tmp_path: Path, mujoco_without_folders: list[str]
) -> None:
    """``model.mjcf.xml`` (no binary model, no sources) compiles from memory too."""
    from harness.recording import Recorder

    text = (
        '<mujoco model="m"><worldbody><body name="b"><joint name="j" type="hinge"/>'
        '<geom type="sphere" size="0.1" mass="1"/></body></worldbody></mujoco>'
    )
    path = tmp_path / "text.mcap"
    metadata = {
        "timestep": "0.002",
        "integrator": "IMPLICITFAST",
        "seed": "0",
        "model_sha256": "",
        "control_modes": "{}",
    }
    Recorder(path, metadata=metadata, attachments={"model.mjcf.xml": text.encode()}).close()
    with Recording(path) as rec:
        model, where = resolve_model(rec)
    assert where.startswith("model.mjcf.xml")
    assert model.nq > 0
    assert "from_file" not in mujoco_without_folders


def test_an_include_not_attached_is_refused_without_looking_in_the_working_folder(
    recorded: Path, robot_files: dict[str, bytes], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The include is missing from the recording but present (a FIFO: an open blocks) in
    the working folder, where MuJoCo resolves a relative name given without a folder: the
    rebuild is refused with one line naming the include."""

    def attach(attachments: dict[str, bytes]) -> dict[str, bytes]:
        kept = {n: b for n, b in attachments.items() if n != "model.mjb"}
        kept["source/model/arm.xml"] = robot_files["arm.xml"]
        kept["source/model/meshes/box.stl"] = robot_files["meshes/box.stl"]
        return kept

    path = _rewrite(recorded, tmp_path / "no-include.mcap", attach)
    work = tmp_path / "work"
    (work / "inc").mkdir(parents=True)
    os.mkfifo(work / "inc" / "assets.xml")
    monkeypatch.chdir(work)
    with Recording(path) as rec, pytest.raises(UnsafeRecordingError) as caught:
        rebuild_robot(rec)
    text = str(caught.value)
    assert "'inc/assets.xml' is not among the recording's attachments" in text
    assert "\n" not in text
