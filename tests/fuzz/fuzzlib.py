"""The fuzz targets and seeds, shared by the hypothesis tests (test_fuzz_*.py) and the
coverage-guided atheris driver (atheris_fuzz.py).

Each target takes bytes and either works or raises the documented HarnessError subclass;
anything else propagates (a bug). ``TARGETS`` maps a name to ``(function, allowed error,
seed bytes)``.
"""

from __future__ import annotations

import importlib.util
import json
import re
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from harness.errors import ConfigError, ModelError, RecordingError
from harness.models import load_robot
from harness.models.sdf import build_spec, read_sdf
from harness.recording import (
    AppliedInput,
    BridgeFrame,
    PhysicsState,
    Recorder,
    Recording,
    RosoutRecord,
)
from harness.recording.inspect import format_report, inspect
from harness.rosbridge import Bridge, TypeRegistry
from harness.scenario import Scenario

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data" / "fuzz"
WORK = Path(tempfile.mkdtemp(prefix="harness-fuzz-"))

URDF_SEED = (DATA / "two_link.urdf").read_bytes()
SDF_SEED = (DATA / "two_link.sdf").read_bytes()
SCENARIO_SEED = (DATA / "scenario.yaml").read_bytes()

INTERESTING = [
    "", "0", "-1", "1e308", "-1e308", "nan", "inf", "-inf", "1 2", "1 2 3 4 5", "x",
    "1e-320", "99999999999999999999", "0 0 0", "-0", "package://nope/x.stl", "../../x",
    "world", "base", "arm", "shoulder", "revolute", "continuous", "fixed", "floating",
    "prismatic", "planar", "true", "[]", "{}", "null", "1.5.1", "\u00e9", "&amp;",
]  # fmt: skip


def frames_seed() -> list[bytes]:
    """Real rosbridge frames of every op (the starting points of the frame mutations)."""
    frames = [
        {"op": "advertise", "topic": "/chatter", "type": "std_msgs/msg/String"},
        {"op": "publish", "topic": "/chatter", "msg": {"data": "hi"}},
        {"op": "subscribe", "topic": "/chatter", "type": "std_msgs/msg/String",
         "throttle_rate": 0, "queue_length": 1, "fragment_size": 10},
        {"op": "subscribe", "topic": "/p", "type": "geometry_msgs/msg/Pose",
         "compression": "cbor"},
        {"op": "publish", "topic": "/p",
         "msg": {"position": {"x": 1, "y": 2, "z": 3},
                 "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}},
        {"op": "unsubscribe", "topic": "/chatter"},
        {"op": "call_service", "service": "/rosapi/topics", "id": "1"},
        {"op": "call_service", "service": "/rosapi/topic_type", "args": {"topic": "/p"}},
        {"op": "advertise_service", "service": "/s", "type": "std_srvs/srv/Trigger"},
        {"op": "service_response", "service": "/s", "id": "service_request:/s:1",
         "values": {"success": True, "message": ""}, "result": True},
        {"op": "send_action_goal", "action": "/a",
         "action_type": "example_interfaces/action/Fibonacci", "args": {"order": 3}, "id": "g"},
        {"op": "advertise_action", "action": "/a", "type": "example_interfaces/action/Fibonacci"},
        {"op": "cancel_action_goal", "action": "/a", "id": "g"},
        {"op": "fragment", "id": "f", "data": '{"op":"pub', "num": 0, "total": 2},
        {"op": "fragment", "id": "f", "data": 'lish","topic":"/chatter","msg":{"data":"x"}}',
         "num": 1, "total": 2},
        {"op": "set_level", "level": "error"},
        {"op": "unadvertise", "topic": "/chatter"},
    ]  # fmt: skip
    return [json.dumps(f).encode() for f in frames]


_REGISTRY: TypeRegistry | None = None


def registry() -> TypeRegistry:
    """One type registry for every fuzzed Bridge (building one costs ~40 ms)."""
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = TypeRegistry()
    return _REGISTRY


def fuzz_frames(data: bytes) -> None:
    """Frames separated by NUL bytes, fed to a fresh Bridge on two connections (text and
    binary). The bridge must never raise: every bad frame becomes a status frame."""
    bridge = Bridge(registry())
    a, b = bridge.connect(), bridge.connect()
    for i, chunk in enumerate(data.split(b"\0")):
        conn = a if i % 2 == 0 else b
        if i % 3 == 2:
            bridge.receive(conn, chunk, i)
        else:
            bridge.receive(conn, chunk.decode("utf-8", errors="replace"), i)
    bridge.disconnect(a)
    bridge.drain()


def _write(name: str, data: bytes) -> Path:
    path = WORK / name
    path.write_bytes(data)
    return path


def fuzz_urdf(data: bytes) -> None:
    """Load (parse, build, compile) a URDF file."""
    load_robot(_write("fuzz.urdf", data), control="position")


def fuzz_sdf(data: bytes) -> None:
    """Read an SDF file and build its MjSpec, then compile it."""
    model = read_sdf(_write("fuzz.sdf", data))
    spec = build_spec(model)
    try:
        spec.compile()
    except ValueError as exc:  # MuJoCo's compiler: the build is refused, not a crash
        raise ModelError(f"compile: {exc}") from None


def fuzz_scenario(data: bytes) -> None:
    """Load and validate a scenario file (YAML)."""
    Scenario.load(_write("fuzz.yaml", data))


def _recording_seed() -> bytes:
    path = WORK / "seed.mcap"
    meta = {
        "timestep": "0.002",
        "integrator": "IMPLICITFAST",
        "seed": "0",
        "model_sha256": "0" * 64,
        "control_modes": "{}",
    }
    state = np.arange(20, dtype=np.float64)
    with Recorder(path, metadata=meta, attachments={"a.txt": b"attachment"},
                  chunk_size=2048) as rec:  # fmt: skip
        for k in range(40):
            rec.write_physics_state(PhysicsState(
                step=k, sim_time_ns=k * 2_000_000, state_spec=1, state=state + k,
                qpos=state[:7], qvel=state[:6],
            ))  # fmt: skip
            if k % 5 == 0:
                rec.write_applied_input(
                    AppliedInput(step=k, sim_time_ns=k * 2_000_000, ctrl=state[:3])
                )
                rec.write_bridge_frame(BridgeFrame(
                    step=k, sim_time_ns=k * 2_000_000, direction=0, connection=1, seq=k,
                    op="publish", topic="/t", text='{"op":"publish","topic":"/t"}',
                ))  # fmt: skip
                rec.write_rosout(
                    RosoutRecord(sim_time_ns=k * 2_000_000, level=20, name="fuzz", msg=f"step {k}")
                )
    return path.read_bytes()


def _read_recording(path: Path) -> None:
    """Open a recording and read everything in it (metadata, attachments, typed records)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # damage warnings are the documented behaviour
        with Recording(path) as rec:
            _ = (rec.metadata, rec.topics, rec.message_count, rec.first_step, rec.last_step)
            for name in rec.attachment_names:
                rec.attachment(name)
            for _state in rec.physics_states():
                pass
            for _input in rec.applied_inputs():
                pass
            for _frame in rec.bridge_frames():
                pass
            for message in rec.messages(["/rosout"]):
                rec.decode(message)


_SHAPES: ModuleType | None = None


def _shapes() -> ModuleType:
    """recording_shapes.py beside this file (imported by path: atheris runs this file's
    folder as a top-level one, pytest as the package tests.fuzz)."""
    global _SHAPES
    if _SHAPES is None:
        spec = importlib.util.spec_from_file_location(
            "recording_shapes", HERE / "recording_shapes.py"
        )
        assert spec is not None
        assert spec.loader is not None
        _SHAPES = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(_SHAPES)
    return _SHAPES


def fuzz_recording(data: bytes) -> None:
    """``data`` as a recipe first: the recording it builds (attachments, metadata, chunk
    shapes: recording_shapes.py) read and inspected under small limits, where a refusal
    must be one line of at most 2000 characters; then ``data`` as a recording file, read."""
    shapes = _shapes()
    shaped = _write("shaped.mcap", shapes.build(data))
    with shapes.small_limits():
        try:
            _read_recording(shaped)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                format_report(inspect(shaped))
        except RecordingError as exc:
            text = str(exc)
            if "\n" in text or len(text) > 2000:
                raise AssertionError(
                    f"not a one-line refusal ({len(text)} chars): {text[:300]!r}"
                ) from None
    _read_recording(_write("fuzz.mcap", data))


Target = tuple[
    Callable[[bytes], None], type[BaseException] | tuple[type[BaseException], ...], bytes
]

_RECORDING_SEED: bytes | None = None


def recording_seed() -> bytes:
    """A small real recording (made once per process)."""
    global _RECORDING_SEED
    if _RECORDING_SEED is None:
        _RECORDING_SEED = _recording_seed()
    return _RECORDING_SEED


def targets() -> dict[str, Target]:
    """name -> (function, the errors it may raise, one seed input)."""
    return {
        "frames": (fuzz_frames, (), b"\0".join(frames_seed())),
        "urdf": (fuzz_urdf, ModelError, URDF_SEED),
        "sdf": (fuzz_sdf, ModelError, SDF_SEED),
        "scenario": (fuzz_scenario, ConfigError, SCENARIO_SEED),
        "recording": (fuzz_recording, RecordingError, recording_seed()),
    }


_VALUE = re.compile(rb'="[^"]*"|: [^\n#]+')


def mutate_values(seed: bytes, picks: list[tuple[int, str]]) -> bytes:
    """Replace attribute values (XML ``="..."``) or YAML scalars (``: ...``) chosen by index
    with interesting values."""
    spans = [m.span() for m in _VALUE.finditer(seed)]
    out = bytearray(seed)
    for index, value in sorted(picks, key=lambda p: -spans[p[0] % len(spans)][0]):
        start, end = spans[index % len(spans)]
        quoted = out[start : start + 2] == b'="'
        new = (f'="{value}"' if quoted else f": {value}").encode()
        out[start:end] = new
    return bytes(out)


def mutate_bytes(seed: bytes, edits: list[tuple[int, int, bytes]]) -> bytes:
    """Apply ``(position, delete_count, insert)`` edits (positions modulo the length)."""
    out = bytearray(seed)
    for pos, delete, insert in edits:
        at = pos % (len(out) + 1)
        out[at : at + delete] = insert
    return bytes(out)
