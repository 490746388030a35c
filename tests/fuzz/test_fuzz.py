"""Hypothesis over bridge frames, URDF, SDF, scenario files and recordings (mutations of real
seeds: interesting values in attributes and scalars, byte edits, JSON subtrees). Every input
either works or raises the documented HarnessError subclass (ModelError, ConfigError,
RecordingError; the bridge never raises), never another exception.

Short by default (derandomised under CI, see conftest.py); ``HARNESS_FUZZ_EXAMPLES=N`` runs N
examples per test (the long run: ``make fuzz``).
"""

from __future__ import annotations

import contextlib
import json
import os
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.rosbridge import Bridge
from tests.fuzz.fuzzlib import (
    INTERESTING,
    frames_seed,
    mutate_bytes,
    mutate_values,
    registry,
    targets,
)

SCALE = int(os.environ.get("HARNESS_FUZZ_EXAMPLES", "0"))
TARGETS = targets()


def examples(default: int) -> Any:
    return settings(
        max_examples=SCALE or default,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


EDITS = st.lists(
    st.tuples(st.integers(0, 10**6), st.integers(0, 24), st.binary(max_size=12)),
    min_size=1,
    max_size=5,
)
PICKS = st.lists(
    st.tuples(st.integers(0, 10**4), st.sampled_from(INTERESTING)), min_size=1, max_size=5
)


def check(name: str, data: bytes) -> None:
    function, allowed, _ = TARGETS[name]
    with contextlib.suppress(allowed):
        function(data)


@pytest.mark.parametrize("name", ["urdf", "sdf", "scenario"])
@examples(30)
@given(picks=PICKS)
def test_interesting_values(name: str, picks: list[tuple[int, str]]) -> None:
    check(name, mutate_values(TARGETS[name][2], picks))


@pytest.mark.parametrize("name", ["urdf", "sdf", "scenario", "recording", "frames"])
@examples(40)
@given(edits=EDITS)
def test_byte_edits(name: str, edits: list[tuple[int, int, bytes]]) -> None:
    check(name, mutate_bytes(TARGETS[name][2], edits))


@examples(40)
@given(data=st.binary(max_size=300))
def test_recording_prefixes_and_garbage(data: bytes) -> None:
    """A recording cut anywhere, or followed or preceded by garbage."""
    seed = TARGETS["recording"][2]
    cut = int.from_bytes(data[:4].ljust(4, b"\0"), "little") % len(seed)
    check("recording", seed[:cut])
    check("recording", seed + data)
    check("recording", seed[:8] + data + seed[8 + len(data) :])


JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats()
    | st.text(max_size=6)
    | st.sampled_from(INTERESTING),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _replace(doc: Any, path: list[int], value: Any) -> Any:
    """``doc`` with the subtree chosen by ``path`` (indices into keys/items) replaced."""
    if not path or not isinstance(doc, (dict, list)) or not doc:
        return value
    if isinstance(doc, dict):
        key = list(doc)[path[0] % len(doc)]
        return {**doc, key: _replace(doc[key], path[1:], value)}
    i = path[0] % len(doc)
    return [*doc[:i], _replace(doc[i], path[1:], value), *doc[i + 1 :]]


@examples(60)
@given(
    picks=st.lists(
        st.tuples(st.integers(0, 100), st.lists(st.integers(0, 20), max_size=4), JSON),
        min_size=1,
        max_size=6,
    )
)
@pytest.mark.slow
def test_frame_json_subtrees(picks: list[tuple[int, list[int], Any]]) -> None:
    """Valid frames with subtrees replaced by arbitrary JSON, on one Bridge in sequence
    (state carries over: advertise, subscribe, calls, fragments)."""
    seeds = [json.loads(f) for f in frames_seed()]
    bridge = Bridge(registry())
    a, b = bridge.connect(), bridge.connect()
    for n, (which, path, value) in enumerate(picks):
        frame = _replace(seeds[which % len(seeds)], path, value)
        for seed in seeds[: which % len(seeds)]:
            bridge.receive(b, json.dumps(seed), n)
        bridge.receive(a, json.dumps(frame), n)
    bridge.disconnect(b)
    bridge.disconnect(a)


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_seed_works(name: str) -> None:
    """The unmutated seeds are valid inputs (else the mutations would test little)."""
    function, _, seed = TARGETS[name]
    function(seed)


@examples(60)
@given(data=st.binary(max_size=400))
def test_recording_shapes(data: bytes) -> None:
    """Recordings built from a recipe: attachments, metadata, chunks of every shape (lying
    sizes, CRCs, times, millions-of-records cousins of the bomb, no summary or a cut one)."""
    check("recording", data)
