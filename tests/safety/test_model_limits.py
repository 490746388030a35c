"""Model resource limits, checked before MuJoCo compiles or reads a model: ``<size>`` user
data, element counts, tree depth, mesh vertices; one ModelLimitError line and exit 2. The
hostile models run in a child process under RLIMIT_AS, so a regression fails instead of
taking the machine's memory."""

from __future__ import annotations

import resource
import struct
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from harness.models import load_robot
from harness.models.files.limits import ModelLimitError, ModelLimits, check_spec

CHILD_MEMORY = 1536 * 2**20
INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)
SIZE_BOMB = (
    '<mujoco><size nuser_body="100000000" nuserdata="1000000000"/>'
    '<worldbody><body><geom size=".1"/></body></worldbody></mujoco>'
)


def _chain(path: Path, links: int) -> Path:
    parts = ['<robot name="chain">']
    parts += [f'<link name="l{i}">{INERTIAL}</link>' for i in range(links)]
    parts += [
        f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(1, links)
    ]
    path.write_text("\n".join([*parts, "</robot>"]))
    return path


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CHILD_MEMORY, CHILD_MEMORY))


def _harness(*args: str) -> subprocess.CompletedProcess[str]:
    code = "import sys; from harness.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limited,
        check=False,
    )


def test_size_bomb_is_refused_before_compiling(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.xml"
    bomb.write_text(SIZE_BOMB)
    assert len(SIZE_BOMB) < 200
    done = _harness("inspect-model", str(bomb))
    assert done.returncode == 2, done.stderr[-500:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "bomb.xml: <size nuser_body> is 100000000, over the limit of 1000" in lines[0]
    with pytest.raises(ModelLimitError, match="nuser_body"):
        load_robot(bomb)


def test_link_count_is_refused_before_mujoco_reads_the_tree(tmp_path: Path) -> None:
    robot = _chain(tmp_path / "long.urdf", 10_001)
    code = (
        "import sys\nfrom harness.models import load_robot\nfrom harness.errors import ModelError\n"
        "try:\n    load_robot(sys.argv[1])\n"
        "except ModelError as e:\n    print(e)\n    sys.exit(2)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(robot)],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limited,
        check=False,
    )
    assert done.returncode == 2, done.stderr[-500:]
    assert "long.urdf: the number of links is 10001, over the limit of 10000" in done.stdout


def test_deep_chain_is_refused_with_the_link_that_is_too_deep(tmp_path: Path) -> None:
    robot = _chain(tmp_path / "deep.urdf", 501)
    with pytest.raises(ModelLimitError, match=r"depth of the link tree \(at link 'l500'\) is 501"):
        load_robot(robot)


def test_mjcf_counts_and_depth_are_checked_on_the_spec() -> None:
    spec = mujoco.MjSpec()
    body = spec.worldbody
    for i in range(12):
        body = body.add_body(name=f"b{i}")
        body.add_geom(size=[0.1, 0, 0])
    with pytest.raises(ModelLimitError, match=r"depth of the body tree \(at body 'b11'\) is 12"):
        check_spec(spec, "x.xml", ModelLimits(tree_depth=10))
    with pytest.raises(ModelLimitError, match="number of geoms is 12"):
        check_spec(spec, "x.xml", ModelLimits(geoms=11))
    check_spec(spec, "x.xml", ModelLimits(tree_depth=12, geoms=12))


def test_mesh_vertices_are_counted_before_compiling(tmp_path: Path) -> None:
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0) for a, b, c in faces)
    stl = b"\0" * 80 + struct.pack("<I", len(faces)) + body
    spec = mujoco.MjSpec()
    spec.assets = {"tet.stl": stl}
    spec.add_mesh(name="tet", file="tet.stl")
    spec.worldbody.add_body().add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="tet")
    with pytest.raises(ModelLimitError, match="mesh vertices is 12, over the limit of 11"):
        check_spec(spec, "m.xml", ModelLimits(mesh_vertices=11))
    check_spec(spec, "m.xml", ModelLimits(mesh_vertices=12))
    assert spec.compile().nmesh == 1


REPLAY_CHILD = """
import sys
from harness.recording import Recorder, Recording
from harness.replay.errors import ModelAttachmentError
from harness.replay.source import resolve_model

path, text = sys.argv[1], sys.argv[2]
metadata = {"timestep": "0.002", "integrator": "IMPLICITFAST", "seed": "0",
            "model_sha256": "", "control_modes": "{}"}
Recorder(path, metadata=metadata, attachments={"model.mjcf.xml": text.encode()}).close()
with Recording(path) as rec:
    try:
        resolve_model(rec)
    except ModelAttachmentError as exc:
        print(exc)
        sys.exit(2)
"""


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (SIZE_BOMB, "<size nuser_body> is 100000000, over the limit"),
        ('<mujoco><include file="/etc/hostname"/></mujoco>', "escapes the model's folder"),
    ],
    ids=["size-bomb", "include-outside"],
)
@pytest.mark.slow
def test_a_recordings_model_attachment_is_data(tmp_path: Path, text: str, expected: str) -> None:
    done = subprocess.run(
        [sys.executable, "-c", REPLAY_CHILD, str(tmp_path / "r.mcap"), text],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limited,
        check=False,
    )
    assert done.returncode == 2, done.stderr[-800:]
    assert expected in done.stdout
