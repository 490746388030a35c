"""The bridge's JSON text is ``json.dumps``'s (compact, UTF-8 kept, floats as ``repr``), with
NaN/Inf as null and bytes as base64, whichever encoder runs underneath."""

from __future__ import annotations

import base64
import json
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from harness.rosbridge.convert import dumps

LEAVES = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8)
)
VALUES = st.recursive(
    LEAVES,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=4)
    ),
    max_leaves=20,
)


@settings(max_examples=200, deadline=None)
@given(VALUES)
def test_dumps_is_compact_json(value: object) -> None:
    assert dumps(value) == json.dumps(value, separators=(",", ":"), ensure_ascii=False)


def test_non_finite_floats_are_null_and_bytes_base64() -> None:
    value = {"a": [1.5, math.nan, -math.inf], "b": {"c": math.inf}, "d": b"\x00\xff", "é": 1e-7}
    text = dumps(value)
    assert json.loads(text) == {
        "a": [1.5, None, None],
        "b": {"c": None},
        "d": base64.b64encode(b"\x00\xff").decode(),
        "é": 1e-7,
    }
    assert '"é":1e-07' in text
