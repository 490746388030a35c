"""Reading a recording costs what its limits allow, not what its bytes can make it cost.

A 77 KB file of one zstd chunk of 27 M empty messages (no summary) took ``harness inspect``
66 s and 885 MB: records are now limited per chunk and per file like bytes
(``HARNESS_MAX_CHUNK_RECORDS``, ``HARNESS_MAX_FILE_RECORDS``), counted while the chunk
decompresses, and a file that is not a harness recording is refused before its first chunk.
The checks here are of the mechanism (how much is decompressed and walked), not of time.
"""

from __future__ import annotations

import itertools
import random
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.writer import Writer

from harness.recording import (
    Recorder,
    Recording,
    RecordingFormatError,
    RecordingLimitError,
    RosoutRecord,
    inflate,
)
from harness.recording import chunks as chunks_module
from harness.recording import scan as scan_module
from harness.recording.chunks import RecordCounter, RecordDamage, record_spans
from harness.replay.errors import RecordedDataError
from harness.replay.source import open_recording
from tests.recording.bombs import MESSAGE_RECORD, write_bomb

HARNESS = [sys.executable, "-m", "harness.cli"]
# Run from elsewhere: the harness imported is the installed one (or $PYTHONPATH's).
ELSEWHERE = {"cwd": "/"}
METADATA = {
    "timestep": "0.002",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


@pytest.fixture(scope="module")
def bomb(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The attack review's file: one zstd chunk of 27 M empty messages, no summary."""
    return write_bomb(tmp_path_factory.mktemp("bomb") / "bomb.mcap")


class Spent:
    """How much the readers decompressed, and how many records of chunks they took in."""

    def __init__(self) -> None:
        self.decompressed = 0
        self.calls = 0
        self.walked = 0


@pytest.fixture
def spent(monkeypatch: pytest.MonkeyPatch) -> Spent:
    """Count the bytes coming out of the decompressor and the records of the chunks the
    scan takes in (those its counter let through)."""
    found = Spent()
    decompress = inflate.decompress
    take_in = scan_module._chunk_records

    def counting_decompress(*args: Any, **kwargs: Any) -> bytes:
        found.calls += 1
        watch = kwargs.get("watch")

        def watching(piece: bytes | memoryview) -> None:
            found.decompressed += len(piece)
            if watch is not None:
                watch(piece)

        kwargs["watch"] = watching
        return decompress(*args, **kwargs)

    def counting_take_in(result: Any, pos: int, data: bytes, starts: Any, last: int) -> Any:
        found.walked += int(starts.size)
        return take_in(result, pos, data, starts, last)

    monkeypatch.setattr(chunks_module.inflate, "decompress", counting_decompress)
    monkeypatch.setattr(scan_module, "_chunk_records", counting_take_in)
    return found


def _one_line_refusal(result: subprocess.CompletedProcess[str], *needles: str) -> None:
    assert result.returncode == 2, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr[-2000:]
    for needle in needles:
        assert needle in result.stderr


def test_inspect_of_the_27m_message_file_refuses_in_one_line(bomb: Path) -> None:
    result = subprocess.run(
        [*HARNESS, "inspect", str(bomb)], capture_output=True, text=True, **ELSEWHERE, timeout=60
    )
    _one_line_refusal(
        result,
        str(bomb),
        "chunk at byte 178",
        f"more than {inflate.DEFAULT_CHUNK_RECORDS} records",
        "HARNESS_MAX_CHUNK_RECORDS",
    )


def test_replay_of_the_27m_message_file_refuses_in_one_line(bomb: Path) -> None:
    result = subprocess.run(
        [*HARNESS, "replay", str(bomb)], capture_output=True, text=True, **ELSEWHERE, timeout=60
    )
    _one_line_refusal(result, str(bomb), "chunk at byte 178", "HARNESS_MAX_CHUNK_RECORDS")


def test_the_27m_message_chunk_is_refused_after_the_limit_not_after_its_records(
    bomb: Path, spent: Spent
) -> None:
    with pytest.raises(RecordingLimitError, match="chunk at byte 178 holds more than 262144"):
        Recording(bomb)
    # Decompressed up to the first record over the limit (in pieces of at most 4 MiB), not
    # the 837 MB the chunk holds; no record walked one by one.
    assert spent.decompressed <= (inflate.DEFAULT_CHUNK_RECORDS + 1) * 31 + 4 * 2**20
    assert spent.walked == 0
    with pytest.raises(RecordingLimitError, match="HARNESS_MAX_CHUNK_RECORDS"):
        open_recording(bomb).close()


def test_records_per_chunk_limit_from_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, spent: Spent
) -> None:
    path = write_bomb(tmp_path / "small.mcap", messages=5000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no summary: truncated after the data section
        with Recording(path) as rec:
            assert rec.message_count == 5000
    monkeypatch.setenv("HARNESS_MAX_CHUNK_RECORDS", "1000")
    spent.walked = 0
    with pytest.raises(RecordingLimitError) as caught:
        Recording(path)
    assert str(caught.value) == (
        f"{path}: chunk at byte 178 holds more than 1000 records, over the limit per chunk "
        "(HARNESS_MAX_CHUNK_RECORDS)"
    )
    assert spent.walked == 0


def test_records_per_file_limit_stops_inside_the_chunk_that_passes_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, spent: Spent
) -> None:
    path = write_bomb(tmp_path / "three.mcap", messages=1000, chunks=3)
    chunk_length = (path.stat().st_size - 178 - 13) // 3
    monkeypatch.setenv("HARNESS_MAX_FILE_RECORDS", "2500")
    with pytest.raises(RecordingLimitError) as caught:
        Recording(path)
    third = 178 + 2 * chunk_length
    assert str(caught.value) == (
        f"{path}: chunk at byte {third} takes the file past 2500 records, over the limit per "
        "file (HARNESS_MAX_FILE_RECORDS)"
    )
    # The first two chunks were read in full; the third only up to the limit.
    assert spent.walked == 2 * 1000


def test_an_indexed_chunk_over_the_limit_is_refused_from_its_index(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, spent: Spent
) -> None:
    path = tmp_path / "indexed.mcap"
    with Recorder(path, metadata=METADATA, chunk_size=2**20) as rec:
        for k in range(3000):
            rec.write_rosout(RosoutRecord(sim_time_ns=k, level=20, name="n", msg="m"))
    with Recording(path) as opened:
        assert opened.complete
        assert len(opened.scan.chunks) == 1
    monkeypatch.setenv("HARNESS_MAX_CHUNK_RECORDS", "2000")
    spent.calls = 0
    for defer in (False, True):
        with pytest.raises(RecordingLimitError, match="over the limit per chunk"):
            Recording(path, defer_chunk_checks=defer)
    assert spent.calls == 0  # refused from the message index, nothing decompressed


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"harness": False}, "no 'harness' metadata record before the first chunk (byte 111)"),
        ({"profile": ""}, "MCAP profile is '', not 'ros2': not a harness recording"),
    ],
)
def test_not_a_harness_recording_is_refused_before_any_chunk(
    tmp_path: Path, spent: Spent, kwargs: dict[str, Any], needle: str
) -> None:
    path = write_bomb(tmp_path / "foreign.mcap", messages=100_000, **kwargs)
    with pytest.raises(RecordingFormatError) as caught:
        Recording(path)
    assert needle in str(caught.value)
    assert spent.calls == 0
    result = subprocess.run(
        [*HARNESS, "inspect", str(path)], capture_output=True, text=True, **ELSEWHERE, timeout=60
    )
    _one_line_refusal(result, needle)


def test_a_complete_foreign_file_is_refused_from_its_summary(tmp_path: Path, spent: Spent) -> None:
    path = tmp_path / "other.mcap"
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="other")
        schema = writer.register_schema("s", "ros2msg", b"")
        channel = writer.register_channel("/x", "cdr", schema)
        for k in range(100):
            writer.add_message(channel, k, b"", k)
        writer.flush()  # type: ignore[no-untyped-call]
        writer.add_metadata("rosbag2", {"x": "1"})
        writer.finish()
    with pytest.raises(RecordingFormatError) as caught:
        Recording(path)
    assert str(caught.value) == (
        f"{path}: no 'harness' metadata record (the summary indexes 'rosbag2'): "
        "not a harness recording"
    )
    assert spent.calls == 0


def test_a_golden_with_its_metadata_after_the_chunks_opens(tmp_path: Path) -> None:
    # write_golden copies a run with mcap's Writer: metadata and attachments after the chunks.
    golden = Path(__file__).resolve().parents[2] / "recordings" / "scenarios" / "demo.mcap"
    with Recording(golden, strict=True) as rec:
        assert rec.scan.chunks[0].offset < min(a.offset for a in rec.scan.attachments)
        assert rec.metadata["format_version"] == "1"
    cut = tmp_path / "cut.mcap"  # no summary: the metadata must come before the first chunk
    cut.write_bytes(golden.read_bytes()[: golden.stat().st_size // 2])
    with pytest.raises(RecordingFormatError, match="no 'harness' metadata record before"):
        Recording(cut)


@pytest.mark.parametrize("value", ["0", "-5", "many"])
def test_a_bad_limit_in_the_environment_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, value: str
) -> None:
    path = write_bomb(tmp_path / "small.mcap", messages=10)
    monkeypatch.setenv("HARNESS_MAX_FILE_RECORDS", value)
    with pytest.raises(
        RecordingFormatError, match=f"HARNESS_MAX_FILE_RECORDS='{value}': expected a positive"
    ):
        Recording(path)


def _records(sizes: list[int]) -> bytes:
    return b"".join(b"\x05" + len(b"x" * n).to_bytes(8, "little") + b"x" * n for n in sizes)


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.integers(0, 40), max_size=60),
    cuts=st.lists(st.integers(0, 4000), max_size=12),
)
def test_the_counter_counts_records_split_anywhere(sizes: list[int], cuts: list[int]) -> None:
    data = _records(sizes)
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    counter = RecordCounter(inflate.InflateLimits(), 0)
    for a, b in itertools.pairwise(points):
        counter(memoryview(data)[a:b])
    assert counter.count == sum(1 for _ in record_spans(data)) == len(sizes)
    assert list(counter.starts) == [start - 9 for _, start, _ in record_spans(data)]
    counter.check_end()
    if sizes and sizes[-1]:  # the last record cut short: it overruns the chunk
        cut = RecordCounter(inflate.InflateLimits(), 0)
        cut(data[:-1])
        with pytest.raises(RecordDamage, match="overruns its container"):
            cut.check_end()


def test_the_counter_stops_at_the_first_record_over_the_limit() -> None:
    limits = inflate.InflateLimits(chunk_records=10, file_records=100)
    counter = RecordCounter(limits, 0)
    with pytest.raises(RecordingLimitError, match="more than 10 records"):
        counter(MESSAGE_RECORD * 1000)
    assert counter.count == 11
    counter = RecordCounter(limits, 95)
    with pytest.raises(RecordingLimitError, match="past 100 records, over the limit per file"):
        counter(MESSAGE_RECORD * 8)
    assert counter.count == 6


def test_an_lz4_and_an_uncompressed_chunk_are_counted_too(tmp_path: Path) -> None:
    limits = inflate.InflateLimits(chunk_records=50)
    data = MESSAGE_RECORD * 200
    import lz4.frame  # type: ignore[import-untyped]

    for compression, raw in (("lz4", lz4.frame.compress(data)), ("", data)):
        counter = RecordCounter(limits, 0)
        with pytest.raises(RecordingLimitError):
            inflate.decompress(compression, raw, len(data), limits, watch=counter)
        assert counter.count == 51
    counter = RecordCounter(inflate.InflateLimits(), 0)
    assert inflate.decompress("lz4", lz4.frame.compress(data), len(data), watch=counter) == data
    assert counter.count == 200


def test_log_time_going_back_is_one_problem_with_a_count(tmp_path: Path) -> None:
    path = tmp_path / "back.mcap"
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=2**16)
        writer.start(profile="ros2", library="test")
        writer.add_metadata("harness", {"format_version": "1", "timestep_ns": "1000"})
        schema = writer.register_schema("s", "ros2msg", b"")
        channel = writer.register_channel("/x", "cdr", schema)
        times = list(range(5000, 0, -1))
        random.Random(0).shuffle(times)
        for t in times:
            writer.add_message(channel, t, b"", t)
        writer.finish()
    with pytest.warns(match="goes back") as caught:
        rec = Recording(path)
    with rec:
        back = [p for p in rec.problems if "goes back" in p.message]
        assert len(back) == 1
        assert back[0].message.endswith("more messages go back in time")
        assert len(str(caught[0].message)) < 1000
    with pytest.raises(RecordedDataError) as refused:
        open_recording(path)
    assert len(str(refused.value)) < 1000
    result = subprocess.run(
        [*HARNESS, "replay", str(path)], capture_output=True, text=True, **ELSEWHERE, timeout=60
    )
    assert result.returncode == 2
    assert len(result.stderr) < 1000
