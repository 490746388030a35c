"""Recordings are data (issue 31, breaks 1 and 5): a model rebuilt from a recording never
expands xacro and never opens a file outside the recording's attachments.

Every entry point that reads a recording runs in a child process on a recording made by the
project's recorder and rewritten with the mcap library:

- the payload recording: its model source is xacro whose ``${...}`` escapes xacro's sandbox
  (``python.vars(...)['__subclasses__']`` -> ``os.system``) and would create a marker file;
  the marker must never appear and rebuilding entry points refuse with one line;
- outside references (absolute path, ``file://``, ``../..``, ``package://`` with the package
  on ``ROS_PACKAGE_PATH``, MJCF ``file``/``meshdir``/``<include>``, SDF ``<uri>`` and
  ``<include>``) point at a FIFO this test made: any open of it, from Python or from MuJoCo's
  C code, blocks, and the child's timeout fails the test; or at a real file watched with
  inotify (the kernel reports any open or read; main's loader skips a FIFO by ``is_file()``
  but reads a real file). The refusal names the reference with the same text whether the
  path is missing, a real file or a FIFO on this machine.
"""

from __future__ import annotations

import ctypes
import json
import os
import re
import struct
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from harness.models import DEMO_URDF, load_robot
from harness.recording import Recorder, Recording, describe_run
from harness.replay import gate
from harness.replay.errors import (
    ModelAttachmentError,
    SourceLeftOutWarning,
    UnsafeRecordingError,
)
from harness.replay.source import rebuild_robot, rebuild_run, resolve_model
from harness.session import Session
from tests.replay import mcap_edit, record_helper

TIMEOUT_S = 60
OLD_GEOMETRY = '<geometry><cylinder radius="0.07" length="0.14"/></geometry>'
XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A physics recording of the demo arm (``base``) and a session recording (``session``,
    what ``--level full`` re-runs), both with the exact model attached."""
    folder = tmp_path_factory.mktemp("gate")
    helper = record_helper
    base = helper.record(folder / "base.mcap", {0: helper.REACH}, 30)
    session = folder / "session.mcap"
    with Session("demo", record_to=session) as live:
        live.set_positions({"joint1": 0.3})
        live.step(20)
    return {"base": base, "session": session}


def _rewrite(src: Path, dst: Path, sources: dict[str, bytes], *, keep_mjb: bool = False) -> Path:
    """A copy of ``src`` whose ``source/model/...`` attachments are ``sources`` (names under
    ``source/``), without ``model.mjb`` unless ``keep_mjb``."""

    def edit(attachments: dict[str, bytes]) -> dict[str, bytes]:
        kept = {
            name: blob
            for name, blob in attachments.items()
            if not name.startswith("source/model/") and (keep_mjb or name != "model.mjb")
        }
        kept.update({f"source/{name}": blob for name, blob in sources.items()})
        return kept

    mcap_edit.rewrite(src, dst, attachments=edit)
    return dst


# -- break 1: a xacro payload -------------------------------------------------------------


def _payload(marker: Path) -> bytes:
    """The demo URDF as xacro whose expression runs ``touch marker`` when expanded."""
    obj = "python.type.mro(python.type)[-1]"
    getattr_ = f"python.vars({obj})['__getattribute__']"
    subclasses = f"python.vars(python.type)['__subclasses__']({obj})"
    expression = (
        f"[{getattr_}({getattr_}(c, '__init__'), '__globals__')['system']('touch {marker}') "
        f"for c in {subclasses} if {getattr_}(c, '__name__') == '_wrap_close'][0]"
    )
    text = DEMO_URDF.read_text().replace("<robot ", f"<robot {XACRO_NS} ", 1)
    extra = f'<xacro:property name="p" value="${{{expression}}}"/><link name="x${{p}}"/>'
    return text.replace("</robot>", extra + "</robot>").encode()


def test_the_payload_runs_when_xacro_expands_it(tmp_path: Path) -> None:
    """The payload is real: expanded by xacro (as main's replay did), it creates the marker."""
    marker = tmp_path / "MARKER"
    source = tmp_path / "robot.urdf.xacro"
    source.write_bytes(_payload(marker))
    from harness.models import expand_xacro

    expand_xacro(source)
    assert marker.exists()


def _harness(*args: str | Path, timeout: float = TIMEOUT_S) -> subprocess.CompletedProcess[str]:
    """``harness ARGS`` in a child process; a timeout fails the test (a blocked open)."""
    command = [sys.executable, "-m", "harness.cli", *map(str, args)]
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"harness {' '.join(map(str, args))} did not finish in {timeout} s (blocked?)")


def _error_line(done: subprocess.CompletedProcess[str]) -> str:
    """The one error line of a refused command (no traceback)."""
    assert "Traceback" not in done.stderr, done.stderr
    errors = [line for line in done.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1, done.stderr
    return errors[0]


ENTRY_POINTS: dict[str, Callable[[Path, Path], list[str | Path]]] = {
    "replay": lambda rec, other: ["replay", rec],
    "replay-full": lambda rec, other: ["replay", "--level", "full", rec],
    "diff-first": lambda rec, other: ["diff", rec, other],
    "diff-second": lambda rec, other: ["diff", other, rec],
    "actuation": lambda rec, other: ["replay", "--actuation", "kinematic", rec],
    "play": lambda rec, other: ["play", rec, "--port", "0", "--start", "now", "--rate", "1000"],
    "inspect": lambda rec, other: ["inspect", rec],
}
REBUILDING = ("replay", "replay-full", "diff-first", "actuation")
"""The entry points that rebuild the model from the sources (the others read none)."""


@pytest.mark.parametrize("model_name", ["robot.urdf.xacro", "robot.urdf"])
@pytest.mark.parametrize("entry", list(ENTRY_POINTS))
def test_xacro_payload_never_runs(
    recordings: dict[str, Path], tmp_path: Path, entry: str, model_name: str
) -> None:
    """Every entry point on the payload recording (a ``.xacro`` model source, or a ``.urdf``
    declaring the xacro namespace): the marker never appears; the entry points that rebuild
    the model refuse with one line saying the xacro source is never expanded."""
    marker = tmp_path / "MARKER"
    source = recordings["session" if entry == "replay-full" else "base"]
    # --actuation and --level full rebuild from the sources even when model.mjb is attached
    keep_mjb = entry in ("replay-full", "actuation")
    payload = _rewrite(
        source, tmp_path / "payload.mcap", {f"model/{model_name}": _payload(marker)},
        keep_mjb=keep_mjb,
    )  # fmt: skip
    done = _harness(*ENTRY_POINTS[entry](payload, source))
    assert not marker.exists(), f"the recording ran code: {done.stdout}{done.stderr}"
    if entry in REBUILDING:
        assert done.returncode != 0
        line = _error_line(done)
        assert f"source/model/{model_name}" in line
        assert "xacro" in line
        assert "never expanded" in line


def test_xacro_source_is_refused_by_the_python_api(
    recordings: dict[str, Path], tmp_path: Path
) -> None:
    """``rebuild_robot`` and ``resolve_model`` (what ``verify``/``diff`` use) refuse it too."""
    marker = tmp_path / "MARKER"
    payload = _rewrite(
        recordings["base"], tmp_path / "payload.mcap", {"model/robot.urdf.xacro": _payload(marker)}
    )
    with Recording(payload) as rec:
        with pytest.raises(UnsafeRecordingError, match="never expanded"):
            rebuild_robot(rec)
        with pytest.raises(UnsafeRecordingError, match="never expanded"):
            resolve_model(rec)
    assert not marker.exists()


# -- break 5: references outside the recording -------------------------------------------


_IN_ACCESS, _IN_OPEN, _IN_NONBLOCK = 0x01, 0x20, 0o4000
_MESH = (Path(__file__).resolve().parents[1] / "data/models/pkg_demo/meshes/tetra.stl").read_bytes()


class OpenWatch:
    """Every open or read of a file in ``folders`` (Linux inotify: the kernel reports it,
    from Python or from MuJoCo's C code alike; looking at a file's status is not reported)."""

    def __init__(self, *folders: Path) -> None:
        libc = ctypes.CDLL(None, use_errno=True)
        self.fd = libc.inotify_init1(_IN_NONBLOCK)
        if self.fd < 0:
            pytest.skip("no inotify here")
        for folder in folders:
            if libc.inotify_add_watch(self.fd, os.fsencode(folder), _IN_OPEN | _IN_ACCESS) < 0:
                pytest.skip(f"cannot watch {folder}")

    def opened(self) -> list[str]:
        """Names of the files opened or read since the last call."""
        names: list[str] = []
        while True:
            try:
                data = os.read(self.fd, 65536)
            except BlockingIOError:
                return names
            offset = 0
            while offset < len(data):
                _, _, _, size = struct.unpack_from("iIII", data, offset)
                name = data[offset + 16 : offset + 16 + size].rstrip(b"\0").decode()
                if name:  # not the folder itself being listed
                    names.append(name)
                offset += 16 + size

    def close(self) -> None:
        os.close(self.fd)


@pytest.fixture(params=["fifo", "regular file"])
def outside_mesh(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Path]:
    """A mesh outside the recording: a FIFO (an open blocks until a writer comes, so the
    child's timeout fails the test), or a real STL file watched for opens."""
    folder = tmp_path / "outside"
    folder.mkdir()
    path = folder / "mesh.stl"
    if request.param == "fifo":
        os.mkfifo(path)
        yield path
        return
    path.write_bytes(_MESH)
    watch = OpenWatch(folder)
    yield path
    try:
        assert watch.opened() == [], "a file outside the recording was opened"
    finally:
        watch.close()


def _outside(kind: str, target: Path) -> str:
    if kind == "absolute":
        return str(target)
    if kind == "file-uri":
        return f"file://{target}"
    return "../" * 40 + str(target).lstrip("/")  # ../../.. from the rebuild folder


def _urdf_with_mesh(reference: str) -> bytes:
    text = DEMO_URDF.read_text()
    assert OLD_GEOMETRY in text
    return text.replace(
        OLD_GEOMETRY, f'<geometry><mesh filename="{reference}"/></geometry>', 1
    ).encode()


@pytest.mark.parametrize("kind", ["absolute", "file-uri", "dotdot"])
@pytest.mark.parametrize("entry", REBUILDING)
def test_outside_mesh_is_never_opened(
    recordings: dict[str, Path], tmp_path: Path, outside_mesh: Path, entry: str, kind: str
) -> None:
    """A URDF mesh outside the recording (absolute, ``file://``, ``../..``) naming a FIFO or
    a watched STL file: every rebuilding entry point refuses with one line naming the
    reference, without opening it."""
    reference = _outside(kind, outside_mesh)
    source = recordings["session" if entry == "replay-full" else "base"]
    recording = _rewrite(
        source, tmp_path / "outside.mcap", {"model/robot.urdf": _urdf_with_mesh(reference)},
        keep_mjb=entry in ("replay-full", "actuation"),
    )  # fmt: skip
    done = _harness(*ENTRY_POINTS[entry](recording, source))
    assert done.returncode != 0
    line = _error_line(done)
    assert f"{reference!r} is outside the recording" in line


# Rebuilds of many kinds of references, run in one child process: each prints its error.
_REBUILD_ALL = r"""
import json, sys, warnings
warnings.simplefilter("ignore")
from harness.errors import HarnessError
from harness.recording import Recording
from harness.replay.source import rebuild_robot, rebuild_run, resolve_model
for path in sys.argv[1:]:
    with Recording(path) as rec:
        try:
            if path.endswith("mjcf-text.mcap"):
                resolve_model(rec)
            else:
                rebuild_robot(rec)
            result = "rebuilt"
        except HarnessError as exc:
            result = f"{type(exc).__name__}: {exc}"
    print(json.dumps([path.rsplit("/", 1)[-1], result]), flush=True)
"""

_INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
)


def _mjcf(body: str, compiler: str = "") -> bytes:
    return (
        f'<mujoco model="m">{compiler}<asset>{body}</asset><worldbody><body name="b">'
        '<joint name="j" type="hinge"/><geom type="box" size="0.1 0.1 0.1"/></body>'
        "</worldbody></mujoco>"
    ).encode()


def _sdf(inner: str) -> bytes:
    return (
        '<?xml version="1.0"?><sdf version="1.9"><model name="m"><link name="base">'
        f"<inertial><mass>1</mass></inertial>{inner}</link></model></sdf>"
    ).encode()


def _reference_cases(target: Path) -> dict[str, dict[str, bytes]]:
    """Recordings (name -> sources) whose model names ``target`` (a file outside) in every
    way a model file can."""
    folder, name = target.parent, target.name
    dotdot = _outside("dotdot", target)
    include_xml = folder.parent / "include.xml"  # the FIFO's sibling: never read either
    return {
        "urdf-absolute": {"model/robot.urdf": _urdf_with_mesh(str(target))},
        "urdf-file-uri": {"model/robot.urdf": _urdf_with_mesh(f"file://{target}")},
        "urdf-dotdot": {"model/robot.urdf": _urdf_with_mesh(dotdot)},
        # a package this machine has on ROS_PACKAGE_PATH, not attached to the recording
        "urdf-package-on-path": {"model/robot.urdf": _urdf_with_mesh(f"package://outside/{name}")},
        "urdf-package-escape": {
            "model/robot.urdf": _urdf_with_mesh("package://pkg/" + "../" * 40 + str(target)[1:]),
            "pkg/package.xml": b"<package><name>pkg</name></package>",
        },
        "mjcf-file": {"model/robot.xml": _mjcf(f'<mesh name="m" file="{target}"/>')},
        "mjcf-meshdir": {
            "model/robot.xml": _mjcf(
                f'<mesh name="m" file="{name}"/>', f'<compiler meshdir="{folder}"/>'
            )
        },
        "mjcf-include": {
            "model/robot.xml": (
                f'<mujoco model="m"><include file="{"../" * 40}{str(include_xml)[1:]}"/>'
                "<worldbody/></mujoco>"
            ).encode()
        },
        "sdf-mesh-uri": {
            "model/robot.sdf": _sdf(
                f'<collision name="c"><geometry><mesh><uri>file://{target}</uri></mesh>'
                "</geometry></collision>"
            )
        },
        "sdf-include-model": {
            "model/robot.sdf": _sdf("").replace(
                b"</model></sdf>",
                b"<include><uri>model://outside</uri></include></model></sdf>",
            )
        },
    }


def _rebuild_all(paths: list[Path], env: dict[str, str]) -> list[list[str]]:
    try:
        done = subprocess.run(
            [sys.executable, "-c", _REBUILD_ALL, *map(str, paths)],
            capture_output=True, text=True, timeout=TIMEOUT_S * 2, env=env, check=False,
        )  # fmt: skip
    except subprocess.TimeoutExpired as exc:
        last = (exc.stdout or b"").decode().strip().splitlines()[-1:] if exc.stdout else []
        pytest.fail(f"a rebuild opened an outside file and blocked (after {last})")
    assert done.returncode == 0, done.stderr
    # (a temporary folder's random name would differ between runs whatever they read)
    text = re.sub(r"harness-replay-[A-Za-z0-9_]+", "harness-replay-X", done.stdout)
    return [json.loads(line) for line in text.splitlines()]


def test_no_reference_kind_reaches_outside_and_the_text_does_not_tell(
    recordings: dict[str, Path], tmp_path: Path
) -> None:
    """URDF (absolute, ``file://``, ``../..``, ``package://`` of a package on
    ``ROS_PACKAGE_PATH`` or escaping its folder), MJCF (``file``, ``meshdir``, ``<include>``),
    SDF (mesh ``<uri>``, ``<include>`` of a ``model://`` on ``GZ_SIM_RESOURCE_PATH``) and the
    attached MJCF text (``model.mjcf.xml`` with an ``<include>``): each outside reference is
    refused without being opened (each is a FIFO, or a folder holding one), with the same text
    whether the file exists on this machine or not."""
    outside = tmp_path / "machine" / "outside"
    outside.mkdir(parents=True)
    target = outside / "mesh.stl"
    cases = _reference_cases(target)
    paths = [
        _rewrite(recordings["base"], tmp_path / f"{name}.mcap", sources)
        for name, sources in cases.items()
    ]

    def mjcf_text(attachments: dict[str, bytes]) -> dict[str, bytes]:
        text = (
            f'<mujoco model="m"><include file="{target.parent.parent / "include.xml"}"/></mujoco>'
        )
        kept = {n: b for n, b in attachments.items() if not n.startswith("source/")}
        return {**kept, "model.mjb": b"not a model", "model.mjcf.xml": text.encode()}

    paths.append(
        mcap_edit.rewrite(
            recordings["base"],
            tmp_path / "mjcf-text.mcap",
            attachments=mjcf_text,
            metadata=lambda m: {k: v for k, v in m.items() if k != "model_sha256"},
        )
    )
    env = {
        **os.environ,
        "ROS_PACKAGE_PATH": str(outside.parent),
        "GZ_SIM_RESOURCE_PATH": str(outside.parent),
    }
    missing = _rebuild_all(paths, env)  # nothing outside exists yet
    # real files, watched: a mesh, an MJCF include, a Gazebo model naming its SDF
    include = outside.parent / "include.xml"
    target.write_bytes(_MESH)
    include.write_text("<mujoco/>")
    (outside / "model.config").write_text("<model><sdf version='1.9'>model.sdf</sdf></model>")
    (outside / "model.sdf").write_bytes(_sdf(""))
    watch = OpenWatch(outside, outside.parent)
    try:
        regular = _rebuild_all(paths, env)
        assert watch.opened() == [], "a file outside the recording was opened"
    finally:
        watch.close()
    for path in (target, include, outside / "model.sdf"):  # FIFOs: an open blocks
        path.unlink()
        os.mkfifo(path)
    fifos = _rebuild_all(paths, env)
    assert regular == missing
    assert fifos == missing
    for name, result in missing:
        assert result.startswith("UnsafeRecordingError: "), (name, result)
        assert (
            "is outside the recording" in result
            or "escapes" in result
            or "is not among the recording's attachments" in result
        ), (name, result)
        assert "\n" not in result


# -- what stays possible ------------------------------------------------------------------


def test_a_xacro_robot_recording_rebuilds_from_its_expanded_urdf(tmp_path: Path) -> None:
    """The recorder attaches a xacro robot's expanded URDF as the model source (with its
    mesh), the xacro files as ``source/xacro/...``: without ``model.mjb`` it rebuilds to the
    recorded model, the xacro file never read."""
    package = tmp_path / "robot"
    (package / "meshes").mkdir(parents=True)
    helper = record_helper
    stl = Path(helper.__file__).resolve().parents[1] / "data"
    meshes = sorted(stl.rglob("*.stl"))
    assert meshes, "tests/data has STL meshes"
    (package / "meshes" / "part.stl").write_bytes(meshes[0].read_bytes())
    (package / "arm.urdf.xacro").write_text(
        f'<?xml version="1.0"?><robot name="arm" {XACRO_NS}>'
        '<xacro:property name="l" value="0.3"/>'
        f'<link name="base"/><link name="a">{_INERTIAL}'
        '<collision><geometry><mesh filename="meshes/part.stl" scale="0.001 0.001 0.001"/>'
        "</geometry></collision></link>"
        '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
        '<origin xyz="0 0 ${l}"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint></robot>'
    )
    robot = load_robot(package / "arm.urdf.xacro")
    described = describe_run(robot)
    attachments = {k: v for k, v in described.attachments.items() if k != "model.mjb"}
    assert "source/xacro/arm.urdf.xacro" in attachments
    path = tmp_path / "xacro.mcap"
    with Recorder(path, metadata=described.metadata, attachments=attachments):
        pass
    (package / "arm.urdf.xacro").write_text("<robot")  # the original is not read again
    with Recording(path) as rec:
        rebuilt = rebuild_robot(rec)
        model, where = resolve_model(rec)
    assert rebuilt.sha256 == described.metadata["model_sha256"]
    assert where.startswith("source attachments")
    assert model.nmesh == 1


def test_a_source_name_leaving_its_folder_is_refused(
    recordings: dict[str, Path], tmp_path: Path
) -> None:
    path = _rewrite(
        recordings["base"], tmp_path / "name.mcap",
        {"model/robot.urdf": DEMO_URDF.read_bytes(), "model/../../escape.stl": b"x"},
    )  # fmt: skip
    with Recording(path) as rec, pytest.raises(UnsafeRecordingError, match="plain relative"):
        rebuild_robot(rec)


def test_model_mjb_is_loaded_first_in_a_limited_child(
    recordings: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``model.mjb`` is loaded in a child process under a memory limit before this process
    loads it: a limit it cannot load within makes the replay fall back (here to the sources)
    instead of loading it here."""
    monkeypatch.setattr(gate, "_PREFLIGHTED", set())
    monkeypatch.setattr(gate, "mjb_memory_limit", lambda size: 16 * 1024**2)
    with Recording(recordings["base"]) as rec:
        _, where = resolve_model(rec)
    assert where.startswith("source attachments"), where
    assert "model.mjb: MuJoCo does not load it within 16 MiB" in where


def test_nothing_recorded_is_unpickled_or_evaluated() -> None:
    """No module of the harness unpickles, ``eval``\\ s, ``exec``\\ s or loads YAML with an
    unsafe loader (xacro's own ``eval`` runs only on local files, never on a recording; so
    does the one ``eval`` allowed here: :mod:`harness.models.xacro.evaluate`, xacro's expression
    evaluated with its steps bounded, which the payload tests above show a replay never
    reaches; and the warm client's ``exec`` of the client program a local scenario names, in
    the forked child that stands for ``python program.py``: the program ``harness run`` would
    start, never a recording's bytes)."""
    root = Path(__file__).resolve().parents[2] / "harness"
    allowed = {
        "models/xacro/evaluate.py: return eval(_compiled(text), symbols, locals_)",
        "scenario/client_zygote.py: exec(code, main.__dict__)",
    }
    banned = ("pickle.load", "marshal.load", "yaml.unsafe_load", "yaml.full_load", "shelve.")
    calls = (" eval(", " exec(", "(eval(", "(exec(")
    found: list[str] = []
    for path in sorted(root.rglob("*.py")):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            suspect = any(b in code for b in banned) or any(c in code for c in calls)
            if suspect and f"{path.relative_to(root)}: {line.strip()}" not in allowed:
                found.append(f"{path.relative_to(root)}:{number}: {line.strip()}")
    assert not found


def test_a_source_name_that_is_also_a_folder_is_one_line(
    recordings: dict[str, Path], tmp_path: Path
) -> None:
    path = _rewrite(
        recordings["base"], tmp_path / "clash.mcap",
        {"model/robot.urdf": DEMO_URDF.read_bytes(), "model/robot.urdf/mesh.stl": b"x"},
    )  # fmt: skip
    with Recording(path) as rec, pytest.raises(ModelAttachmentError, match="cannot be written"):
        rebuild_robot(rec)


def test_a_world_including_a_bundled_gazebo_model_still_rebuilds(tmp_path: Path) -> None:
    """The harness's own data (here the bundled ``model://ground_plane`` a world includes)
    is part of the program, not of the machine: a rebuild may read it."""
    import harness.models.sdf.worldfile as worldfile

    path = tmp_path / "world.mcap"
    with Session("demo", scene=worldfile.BUNDLED_MODELS.parent / "worlds" / "mobile_room.world",
                 record_to=path) as live:  # fmt: skip
        live.step(5)
    with Recording(path) as rec:
        rebuilt = rebuild_run(rec)
        assert rebuilt.sha256 == rec.metadata["model_sha256"]


def test_a_xacro_source_beside_the_expanded_description_is_left_out_with_a_note(
    recordings: dict[str, Path], tmp_path: Path
) -> None:
    """With the expanded URDF attached, a xacro source beside it is left out (a
    ``SourceLeftOutWarning`` names it) and the robot rebuilds from the URDF."""
    marker = tmp_path / "MARKER"
    path = _rewrite(
        recordings["base"], tmp_path / "both.mcap",
        {"model/demo_arm.urdf": DEMO_URDF.read_bytes(),
         "model/robot.urdf.xacro": _payload(marker)},
    )  # fmt: skip
    with Recording(path) as rec:
        with pytest.warns(SourceLeftOutWarning, match="robot.urdf.xacro"):
            rebuilt = rebuild_robot(rec)
        assert rebuilt.sha256 == rec.metadata["model_sha256"]
    assert not marker.exists()
