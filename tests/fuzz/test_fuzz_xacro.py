"""Hypothesis over xacro documents: macros (parameters, defaults, blocks, recursion, calls by
name), properties (lazy, block, doubling strings), arguments, conditionals, includes of
missing, optional and existing files, comments, text expressions, and byte edits that break
the XML. Every document either expands or raises a ModelError of one line (an expansion
limit among them); nothing else, and nothing runs past the limits. The expansion under the
harness's meter writes exactly what xacro alone writes.

Short by default; ``HARNESS_FUZZ_EXAMPLES=N`` runs N examples per test (``make fuzz``).
"""

from __future__ import annotations

import os
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.errors import ModelError
from harness.models.xacro.expand import expand_xacro
from tests.fuzz.fuzzlib import mutate_bytes
from tests.fuzz.xacrofuzz import XACRO_SEED, fuzz_xacro, raw_expansions, write

SCALE = int(os.environ.get("HARNESS_FUZZ_EXAMPLES", "0"))


def examples(default: int) -> Any:
    return settings(
        max_examples=SCALE or default,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


MACROS = st.sampled_from(["m0", "m1", "m2", "part"])
PROPERTIES = st.sampled_from(["p0", "p1", "p2", "r"])
VALUES = st.sampled_from(
    [
        "1", "0.5", "-2", "ab", "true", "false", "0", "", "x y", "${p0}", "${p1+p1}",
        "${p0*2}", "${p2}", "${r}", "$(arg a0)", "$(arg nope)", "${undefined}", "${1/0}",
        "${'x'*3}", "${[1, 2][5]}", "${xacro.load_yaml('nope.yaml')}", "${python.len(p0)}",
        "${p0 if p1 else p2}", "$(find nowhere_pkg)", "${{", "$", "${__import__}",
        "${python.range(3)}", "${dict(a=1)}", "${x}", "${b}",
    ]
)  # fmt: skip
PARAMS = st.sampled_from(["", "x", "x:=1", "x *b", "x:=^|2 *b", "**b", "x y:=${r}", "x x"])
FILES = st.sampled_from(
    ["missing.xacro", "part.xacro", "/nonexistent/abs.xacro", "$(find nowhere_pkg)/a.xacro", ""]
)

LEAVES = st.one_of(
    st.builds('<link name="{}"/>'.format, VALUES),
    st.builds('<xacro:property name="{}" value="{}"/>'.format, PROPERTIES, VALUES),
    st.builds(
        '<xacro:property name="{}"><origin xyz="{}"/></xacro:property>'.format,
        PROPERTIES,
        VALUES,
    ),
    st.builds('<xacro:{0} x="{1}"><origin/></xacro:{0}>'.format, MACROS, VALUES),
    st.builds("<xacro:{}/>".format, MACROS),
    st.builds('<xacro:call macro="{}" x="{}"/>'.format, MACROS, VALUES),
    st.just('<xacro:insert_block name="b"/>'),
    st.builds(
        '<xacro:include filename="{}" optional="{}"/>'.format,
        FILES,
        st.sampled_from(["true", "false"]),
    ),
    st.builds('<xacro:arg name="a0" default="{}"/>'.format, VALUES),
    st.builds('<xacro:element xacro:name="{}"/>'.format, VALUES),
    st.builds('<xacro:attribute name="{}" value="{}"/>'.format, VALUES, VALUES),
    st.builds("<!-- {} -->".format, VALUES),
    VALUES,
)


def _block(children: st.SearchStrategy[list[str]]) -> st.SearchStrategy[str]:
    body = children.map("".join)
    return st.one_of(
        st.builds('<xacro:if value="{}">{}</xacro:if>'.format, VALUES, body),
        st.builds('<xacro:unless value="{}">{}</xacro:unless>'.format, VALUES, body),
        st.builds("<visual>{}</visual>".format, body),
        st.builds(
            '<xacro:macro name="{}" params="{}">{}</xacro:macro>'.format, MACROS, PARAMS, body
        ),
    )


ELEMENTS = st.recursive(
    LEAVES, lambda inner: _block(st.lists(inner, min_size=1, max_size=3)), max_leaves=12
)
DOCUMENTS = st.lists(ELEMENTS, min_size=1, max_size=8).map(
    lambda parts: (
        '<?xml version="1.0"?>\n<robot name="gen" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        + "\n".join(parts)
        + "\n</robot>\n"
    ).encode()
)
EDIT = st.tuples(st.integers(0, 10**4), st.integers(0, 8), st.binary(max_size=6))
EDITS = st.lists(EDIT, max_size=2)


def _expand(data: bytes) -> None:
    message = "expanded"
    try:
        fuzz_xacro(data)
    except ModelError as exc:
        message = str(exc)
    assert message
    assert "\n" not in message, repr(message)


@examples(60)
@given(document=DOCUMENTS, edits=EDITS)
def test_generated_xacro_expands_or_is_one_model_error(document: bytes, edits: list[Any]) -> None:
    _expand(mutate_bytes(document, edits) if edits else document)


@examples(40)
@given(edits=st.lists(EDIT, min_size=1, max_size=4))
def test_seed_byte_edits_expand_or_are_one_model_error(edits: list[Any]) -> None:
    _expand(mutate_bytes(XACRO_SEED, edits))


@examples(40)
@given(document=DOCUMENTS)
def test_the_meter_changes_no_output(document: bytes) -> None:
    """Where plain xacro expands a document, xacro under the harness's meter (its one-pass
    splice for replace_node among the hooks) writes the same bytes; where plain xacro fails,
    the metered one fails too."""
    plain, counted = raw_expansions(write("diff.urdf.xacro", document))
    if plain[0] == "ok":
        assert counted == plain
    else:
        assert counted[0] != "ok"


def test_seed_expands() -> None:
    """The seed is a valid robot (else its byte edits would test little)."""
    expansion = expand_xacro(write("seed.urdf.xacro", XACRO_SEED))
    assert b'<link name="wheel_rearr">' in expansion.urdf
    assert b'<link name="part_1"/>' in expansion.urdf
