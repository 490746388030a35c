"""One xacro ``${...}`` expression bounded while Python evaluates it (issue 31, break 7): a
repetition, power, shift, widening string method, comprehension, range, method or lambda
called in a loop, or a class C code iterates without end, that would make gigabytes or run
for hours inside one ``eval`` is stopped before it runs, with one
:class:`~harness.models.files.limits.ModelLimitError` line naming the file (exit 2 on the CLI).

Each bomb runs in ``harness check-model`` in a subprocess with a memory limit (1 GiB of
address space) and a hang guard; before the guard each ran out of memory or past the guard
(the expression was only measured once it had been computed).
"""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from harness.models.files.limits import XACRO_LIMITS, ModelLimitError, XacroLimits
from harness.models.xacro.evaluate import guarded_eval
from harness.models.xacro.meter import XacroMeter

HEAD = '<?xml version="1.0"?>\n<robot name="bomb" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
HANG_GUARD = 120  # seconds: each bomb is refused in well under one on an idle machine
MEMORY = 2**30

TEMPLATE = (
    '<xacro:property name="t" value="{:&gt;10000000000}"/>'
    '<xacro:property name="x" value="${python.range(10**6)}"/>'
)
BOMBS = {
    "string-repetition": "'x'*10**10",
    "list-repetition": "[0]*10**10",
    "power": "2**10**10",
    "shift": "1 &lt;&lt; 10**10",
    "comprehension-over-range": "[i for i in python.range(10**9)]",
    "sum-of-range": "python.sum(python.range(10**12))",
    "ljust": "'x'.ljust(10**10)",
    "replace-empty": "('x'*10**6).replace('', 'x'*10**6)",
    "format-width": "t.format(1)",
    "percent-width": "'%10000000000d' % 1",
    "round-digits": "round(5, -10**9)",
    "factorial": "python.len(python.str(math.factorial(10**7)))",
    "map-of-copies": "len(python.list(python.map(python.list, [python.range(10**6)]*10**4)))",
    "squares-of-properties": "q30",
    # an object that C code iterates without end (its __getitem__ never raises)
    "endless-class": "python.all(python.type('Z', (), python.dict(__getitem__=python.slice))())",
    "count-in-a-loop": "[([0]*10**6).count(0) for i in python.range(10**6)]",
    "lambda-in-a-loop": "[len(python.list(python.map(lambda x: x, [1]*10**6))) for i in x]",
}


def _squares() -> str:
    """q0 = 2**60, q(i) = q(i-1) * q(i-1): 60 * 2**30 bits after 30 properties."""
    lines = ['<xacro:property name="q0" value="${2**60}"/>']
    lines += [f'<xacro:property name="q{i}" value="${{q{i - 1}*q{i - 1}}}"/>' for i in range(1, 31)]
    return "".join(lines)


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def _check_model(path: Path) -> str:
    """``harness check-model path`` under the memory limit: its one line (exit 2)."""
    done = subprocess.run(
        [sys.executable, "-m", "harness", "check-model", str(path)],
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
        preexec_fn=_limited,
        env=dict(os.environ),
        check=False,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 2, output[-2000:]
    lines = output.strip().splitlines()
    assert len(lines) == 1, output[-2000:]
    return lines[0]


@pytest.mark.parametrize("name", sorted(BOMBS))
def test_an_expression_bomb_is_refused_before_it_runs(name: str, tmp_path: Path) -> None:
    path = tmp_path / f"{name}.urdf.xacro"
    extra = TEMPLATE + (_squares() if name == "squares-of-properties" else "")
    path.write_text(
        f'{HEAD}{extra}<xacro:property name="p" value="${{{BOMBS[name]}}}"/>'
        '<link name="l${python.len(python.str(p))}"/></robot>\n'
    )
    line = _check_model(path)
    assert line.startswith(f"{path}: does not load: {path}: xacro expansion stopped: "), line


BENIGN = [
    "[i * 2 for i in python.range(5) if i % 2]",
    "' '.join([python.str(v) for v in [1.5, 2, 'a']])",
    "'%.3f %s' % (math.pi, 'x')",
    "'{:.2f}'.format(2.0 / 3)",
    "python.sorted(['bb', 'a', 'ccc'], key=python.len)",
    "python.sorted([3, 1, 2], key=lambda x: -x)",
    "python.list(python.map(python.abs, [-1, 2, -3]))",
    "max([1, 5, 3]) + min(4, 2) ** 3",
    "'ab' * 3 + 'c'.ljust(4, '.') + 'x'.replace('x', 'yz')",
    "[1, 2, 3][1:] + [4] * 2",
    "2 ** 10 + (1 << 5) - 7 // 2 + 7 % 3",
    "python.dict(a=1, b=[1, 2])['b'][-1]",
    "round(math.radians(90), 4)",
    "'a' in 'cat' and 3 not in [1, 2]",
    "python.sum(x for x in python.range(4))",
]


@pytest.mark.parametrize("expression", BENIGN)
def test_the_guard_changes_no_value(expression: str) -> None:
    """What a real xacro writes evaluates to what Python's ``eval`` gives."""
    symbols: dict[str, Any] = {
        "python": _Namespace(__builtins__),
        "math": _Namespace(vars(math)),
        "max": max,
        "min": min,
        "round": round,
    }
    expected = eval(expression, {**symbols, "__builtins__": {}})
    meter = XacroMeter(XACRO_LIMITS)
    assert guarded_eval(expression, symbols, None, meter, ValueError) == expected


def test_a_property_named_like_a_guard_helper_is_refused() -> None:
    symbols: dict[str, Any] = {"__hx_call": print}
    with pytest.raises(ValueError, match="__hx_call"):
        guarded_eval("1 + 1", symbols, None, XacroMeter(XACRO_LIMITS), ValueError)


def test_a_step_is_charged_before_it_is_made() -> None:
    """The meter stops ``'x' * n`` at its text budget before the string exists."""
    meter = XacroMeter(XacroLimits(text_bytes=1000))
    with pytest.raises(ModelLimitError, match="more than 1000 bytes of text"):
        guarded_eval("'x' * 1001", {}, None, meter, ValueError)
    assert guarded_eval("'x' * 10", {}, None, XacroMeter(XacroLimits(text_bytes=1000)), ValueError)


class _Namespace(dict[str, Any]):
    """xacro's ``python.name`` / ``math.name`` attribute access."""

    def __init__(self, names: Any) -> None:
        super().__init__(names if isinstance(names, dict) else vars(names))

    def __getattr__(self, name: str) -> Any:
        return self[name]
