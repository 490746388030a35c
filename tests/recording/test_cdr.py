"""The hand-laid CDR encoders give exactly rosbags' bytes (every length and alignment)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.recording.cdr import bridge_frame, physics_state
from harness.recording.layout import TYPE_BRIDGE_FRAME, TYPE_PHYSICS_STATE, typestore


@pytest.mark.parametrize("sizes", [(0, 0, 0), (0, 0, 1), (1, 0, 0), (3, 2, 1), (131, 9, 8)])
def test_physics_state_matches_rosbags(sizes: tuple[int, int, int]) -> None:
    store = typestore()
    rng = np.random.default_rng(sum(sizes))
    state, qpos, qvel = (rng.standard_normal(n) for n in sizes)
    msg = store.types[TYPE_PHYSICS_STATE](
        step=2**40 + 3, sim_time_ns=-5, state_spec=8191, state=state, qpos=qpos, qvel=qvel
    )
    expected = store.serialize_cdr(msg, TYPE_PHYSICS_STATE)
    assert physics_state(2**40 + 3, -5, 8191, state, qpos, qvel) == expected


@pytest.mark.parametrize("op", ["", "a", "ab", "abc", "publish"])
@pytest.mark.parametrize("topic", ["", "/t", "/joint_states", "/ä"])
@pytest.mark.parametrize(
    "payload",
    [
        ("{}", None),
        ("", None),
        ("xyz\u00e9", None),
        (None, b""),
        (None, b"\x00\x01\x02"),
        (None, bytes(range(9))),
    ],
)
def test_bridge_frame_matches_rosbags(
    op: str, topic: str, payload: tuple[str | None, bytes | None]
) -> None:
    store = typestore()
    text, data = payload
    msg = store.types[TYPE_BRIDGE_FRAME](
        step=7,
        sim_time_ns=1_000_000,
        direction=1,
        connection=3,
        seq=2**33,
        op=op,
        topic=topic,
        binary=data is not None,
        text=text or "",
        data=np.frombuffer(data or b"", np.uint8),
    )
    expected = store.serialize_cdr(msg, TYPE_BRIDGE_FRAME)
    assert bridge_frame(7, 1_000_000, 1, 3, 2**33, op, topic, text, data) == expected
