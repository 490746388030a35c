"""Decompression bombs: a chunk is decompressed into at most a limit of our own (per chunk and
per file, set by ``HARNESS_MAX_CHUNK_BYTES``/``HARNESS_MAX_FILE_BYTES``), never into the size
the file declares; lz4 too, incrementally. The bombs run through ``harness inspect`` and
``harness replay`` in a child process under RLIMIT_AS, so a regression fails instead of
taking the machine's memory."""

from __future__ import annotations

import os
import resource
import struct
import subprocess
import sys
from pathlib import Path

import lz4.frame  # type: ignore[import-untyped]
import numpy as np
import pytest
import zstandard

from harness.recording import PhysicsState, Recorder, Recording, RecordingFormatError
from harness.recording.inflate import InflateError, InflateLimits, decompress
from harness.recording.scan import scan

METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}
MAGIC = b"\x89MCAP0\r\n"
ZEROS = bytes(8 * 2**20)
CHILD_MEMORY = 700 * 2**20  # the CLI needs ~300 MB of address space; a bomb needs GBs


def _record(opcode: int, body: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(body)) + body


def _valid(path: Path, states: int = 1, chunk_size: int = 1024 * 1024) -> bytes:
    rec = Recorder(path, metadata=METADATA, chunk_size=chunk_size)
    state = np.random.default_rng(0).random(500)
    for k in range(states):
        rec.write_physics_state(
            PhysicsState(
                step=k, sim_time_ns=k, state_spec=1, state=state, qpos=state[:3], qvel=state[:3]
            )
        )
    rec.close()
    return path.read_bytes()


def _bomb(tmp_path: Path, compression: str, payload: bytes, declared: int) -> Path:
    """A harness recording whose first chunk is ``payload`` claiming ``declared`` bytes."""
    ok = _valid(tmp_path / "ok.mcap")
    first = scan(memoryview(ok), "ok").chunks[0].offset
    name = compression.encode()
    body = (
        struct.pack("<QQQI", 0, 0, declared, 0)
        + struct.pack("<I", len(name))
        + name
        + struct.pack("<Q", len(payload))
        + payload
    )
    tail = _record(0x06, body) + _record(0x0F, struct.pack("<I", 0))
    tail += _record(0x02, struct.pack("<QQI", 0, 0, 0)) + MAGIC
    path = tmp_path / f"bomb-{compression}.mcap"
    path.write_bytes(ok[:first] + tail)
    return path


def _zstd_zeros(n: int) -> bytes:
    c = zstandard.ZstdCompressor().compressobj()  # streamed: the frame has no content size
    return b"".join([c.compress(ZEROS) for _ in range(n // len(ZEROS))] + [c.flush()])


def _lz4_zeros(n: int) -> bytes:
    c = lz4.frame.LZ4FrameCompressor()
    parts = [c.begin()] + [c.compress(ZEROS) for _ in range(n // len(ZEROS))]
    return b"".join([*parts, c.flush()])


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (CHILD_MEMORY, CHILD_MEMORY))


def _harness(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    code = "import sys; from harness.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limited,
        env={**os.environ, **(env or {})},
        check=False,
    )


@pytest.mark.slow
def test_zstd_chunk_declaring_4_gib_is_refused_by_our_limit(tmp_path: Path) -> None:
    path = _bomb(tmp_path, "zstd", _zstd_zeros(8 * 2**20), 4 * 2**30)
    inspect = _harness("inspect", str(path))
    assert inspect.returncode == 1, inspect.stderr
    assert "chunk declares 4294967296 bytes decompressed, over the limit" in inspect.stdout
    replay = _harness("replay", str(path))
    assert replay.returncode == 2
    assert "over the limit of 1073741824 (HARNESS_MAX_CHUNK_BYTES)" in replay.stderr
    assert "Traceback" not in replay.stderr


def test_lz4_bomb_is_decompressed_incrementally_under_the_bound(tmp_path: Path) -> None:
    path = _bomb(tmp_path, "lz4", _lz4_zeros(256 * 2**20), 1000)
    inspect = _harness("inspect", str(path))
    assert inspect.returncode == 1, inspect.stderr
    assert "chunk decompresses to more than the 1000 bytes it declares" in inspect.stdout


def test_a_frame_lying_about_its_size_reads_at_most_one_byte_more() -> None:
    limits = InflateLimits(chunk_bytes=2**20)
    with pytest.raises(InflateError, match="more than the 4096 bytes"):
        decompress("zstd", zstandard.ZstdCompressor().compress(ZEROS), 4096, limits)
    with pytest.raises(InflateError, match="more than the 4096 bytes"):
        decompress("lz4", lz4.frame.compress(ZEROS), 4096, limits)
    with pytest.raises(InflateError, match="over the limit of 1048576"):
        decompress("zstd", zstandard.ZstdCompressor().compress(ZEROS), len(ZEROS), limits)
    assert decompress("lz4", lz4.frame.compress(b"abc" * 100), 300, limits) == b"abc" * 100
    with pytest.raises(InflateError, match="lz4 chunk ends before its frame does"):
        decompress("lz4", lz4.frame.compress(b"abc" * 100)[:-6], 300, limits)


def test_limits_are_configurable_per_chunk_and_per_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "rec.mcap"
    _valid(path, states=200, chunk_size=16 * 1024)
    with Recording(path, strict=True) as rec:
        chunks = len(rec.scan.chunks)
    assert chunks > 4
    data = memoryview(path.read_bytes())
    monkeypatch.setenv("HARNESS_MAX_FILE_BYTES", str(3 * 16 * 1024))
    problems = [str(p) for p in scan(data, "rec").problems]
    assert any("over the limit of 49152 (HARNESS_MAX_FILE_BYTES)" in p for p in problems)
    monkeypatch.setenv("HARNESS_MAX_FILE_BYTES", "")
    monkeypatch.setenv("HARNESS_MAX_CHUNK_BYTES", "1000")
    assert any("over the limit of 1000" in str(p) for p in scan(data, "rec").problems)
    monkeypatch.setenv("HARNESS_MAX_CHUNK_BYTES", "lots")
    # A bad setting is the reader's, not damage of the file: refused in one line.
    with pytest.raises(RecordingFormatError, match="rec: HARNESS_MAX_CHUNK_BYTES='lots'"):
        scan(data, "rec")
