"""xacro expansion bounded while it runs: a 2 KB file of doubling macros, a string that doubles,
a YAML file of aliases, comments that multiply and runaway recursion are each stopped at a
limit of :class:`~harness.models.files.limits.XacroLimits` with one line naming the file, what ran
over and the limit (exit 2 on the CLI), long before they hold the machine; every limit can be
changed by its ``HARNESS_MAX_XACRO_*`` variable; real robots expand far below the defaults.

The bombs run in a subprocess with a memory limit and a generous hang guard (before the
limits, each ran until killed: minutes and gigabytes)."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from harness.models.errors import XMLError
from harness.models.files.limits import ModelLimitError
from harness.models.xacro.expand import clear_cache, expand_xacro

DESCRIPTIONS = Path(__file__).resolve().parents[1] / "data" / "descriptions"
UR = DESCRIPTIONS / "ur_description" / "urdf" / "ur_mocked.urdf.xacro"
MULTI_ARM = DESCRIPTIONS / "franka_description" / "robots" / "multi_arm" / "multi_arm.urdf.xacro"
HEAD = '<?xml version="1.0"?>\n<robot name="bomb" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
HANG_GUARD = 120  # seconds: a few seconds on an idle machine, 15 s on two cores shared by 8
MEMORY = 4 * 2**30


def doubling_macros(levels: int = 22) -> str:
    """Macro i calls macro i+1 twice: 2**levels links from one call (about 1.6 KB)."""
    lines = [HEAD]
    for i in range(levels):
        lines.append(f'  <xacro:macro name="m{i}"><xacro:m{i + 1}/><xacro:m{i + 1}/></xacro:macro>')
    lines.append(f'  <xacro:macro name="m{levels}"><link name="l"/></xacro:macro>')
    lines.append("  <xacro:m0/>\n</robot>\n")
    return "\n".join(lines)


def doubling_string(levels: int = 40) -> str:
    """Property i is property i-1 twice: 16 * 2**39 characters asked for in 2 KB."""
    lines = [HEAD, '  <xacro:property name="s0" value="xxxxxxxxxxxxxxxx"/>']
    for i in range(1, levels):
        lines.append(f'  <xacro:property name="s{i}" value="${{s{i - 1}+s{i - 1}}}"/>')
    lines.append(f'  <link name="${{s{levels - 1}}}"/>\n</robot>\n')
    return "\n".join(lines)


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def _cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "harness", *args],
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
        preexec_fn=_limited,
        env={**os.environ, **(env or {})},
        check=False,
    )


def _one_line(done: subprocess.CompletedProcess[str]) -> str:
    """The one line a refused model prints (inspect-model: an error on stderr; check-model:
    its "does not load" report on stdout), exit code 2."""
    output = done.stdout + done.stderr
    assert done.returncode == 2, output
    lines = output.strip().splitlines()
    assert len(lines) == 1, output
    return lines[0]


@pytest.fixture(autouse=True)
def _no_cached_expansions():
    clear_cache()
    yield
    clear_cache()


def test_doubling_macro_bomb_is_refused_at_the_element_limit(tmp_path):
    path = tmp_path / "bomb.urdf.xacro"
    path.write_text(doubling_macros(22))
    assert path.stat().st_size < 2048
    line = _one_line(_cli("inspect-model", str(path)))
    assert line.startswith("harness inspect-model: error: ")
    assert f"{path}: xacro expansion stopped: more than 50000 elements" in line
    assert "HARNESS_MAX_XACRO_ELEMENTS" in line


def test_doubling_string_bomb_is_refused_at_the_text_limit(tmp_path):
    path = tmp_path / "strings.urdf.xacro"
    path.write_text(doubling_string(40))
    line = _one_line(_cli("check-model", str(path)))
    assert line.startswith(f"{path}: does not load: ")
    assert f"{path}: xacro expansion stopped: more than 33554432 bytes of text" in line
    assert "HARNESS_MAX_XACRO_TEXT_BYTES" in line


def test_yaml_aliases_are_measured_not_written_out(tmp_path):
    """Nine levels of ten aliases each: 10**9 leaves that share storage; writing the value
    into an attribute would take forever, measuring it stops at the limit."""
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 10):
        lines.append(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]")
    (tmp_path / "aliases.yaml").write_text("\n".join(lines) + "\n")
    path = tmp_path / "yaml.urdf.xacro"
    load = f"xacro.load_yaml('{tmp_path}/aliases.yaml')"
    path.write_text(
        f'{HEAD}<xacro:property name="y" value="${{{load}}}"/><link name="${{y}}"/></robot>'
    )
    done = _cli("inspect-model", str(path), env={"HARNESS_MAX_XACRO_TEXT_BYTES": "1000000"})
    line = _one_line(done)
    assert "xacro expansion stopped: more than 1000000 bytes of text" in line


def test_comments_count_as_output(tmp_path):
    """A 100 KB comment in a macro called 400 times: 40 MB of output from 105 KB."""
    path = tmp_path / "comments.urdf.xacro"
    calls = "".join("<xacro:c/>" for _ in range(400))
    path.write_text(
        f'{HEAD}<xacro:macro name="c"><!-- {"x" * 100_000} --><link name="l"/></xacro:macro>'
        f"{calls}</robot>"
    )
    with pytest.raises(ModelLimitError, match="more than 33554432 bytes of text"):
        expand_xacro(path)


def test_runaway_recursion_is_the_depth_limit(tmp_path):
    path = tmp_path / "recursion.urdf.xacro"
    path.write_text(f'{HEAD}<xacro:macro name="r"><xacro:r/></xacro:macro><xacro:r/></robot>')
    with pytest.raises(ModelLimitError) as caught:
        expand_xacro(path)
    assert str(caught.value) == (
        f"{path}: xacro expansion stopped: elements and macro calls nested more than 100 deep "
        "(the limit; HARNESS_MAX_XACRO_DEPTH changes it)"
    )


@pytest.mark.parametrize(
    ("variable", "value", "what"),
    [
        ("HARNESS_MAX_XACRO_ELEMENTS", "100", "more than 100 elements"),
        ("HARNESS_MAX_XACRO_EXPRESSIONS", "50", "more than 50 expressions"),
        ("HARNESS_MAX_XACRO_TEXT_BYTES", "1000", "more than 1000 bytes of text"),
        ("HARNESS_MAX_XACRO_DOM_WORK", "1000", "more than 1000 DOM sibling scans"),
        ("HARNESS_MAX_XACRO_DEPTH", "3", "elements and macro calls nested more than 3 deep"),
        ("HARNESS_MAX_XACRO_SECONDS", "1e-9", "it ran longer than 1e-09 s"),
    ],
)
def test_every_limit_is_set_by_its_variable(monkeypatch, variable, value, what):
    monkeypatch.setenv(variable, value)
    with pytest.raises(ModelLimitError) as caught:
        expand_xacro(UR, {"ur_type": "ur5e", "name": "ur"})
    message = str(caught.value)
    assert "\n" not in message
    assert message.split(": ", 1)[0].endswith(".xacro")  # the file it was expanding
    assert message.endswith(f"xacro expansion stopped: {what} (the limit; {variable} changes it)")


@pytest.mark.parametrize("value", ["abc", "0", "-5", "nan"])
def test_a_bad_limit_variable_is_one_line(monkeypatch, value):
    monkeypatch.setenv("HARNESS_MAX_XACRO_ELEMENTS", value)
    with pytest.raises(ModelLimitError, match=r"^HARNESS_MAX_XACRO_ELEMENTS='.*': expected a"):
        expand_xacro(UR, {"ur_type": "ur5e", "name": "ur"})


def test_real_robots_expand_far_below_the_defaults(monkeypatch):
    """Two Franka arms with their hands on one base (the largest robot in tests/data) still
    expand with every count limited to a twentieth of its default (nesting: a fifth)."""
    for variable, value in {
        "HARNESS_MAX_XACRO_ELEMENTS": 50_000 // 20,
        "HARNESS_MAX_XACRO_EXPRESSIONS": 500_000 // 20,
        "HARNESS_MAX_XACRO_TEXT_BYTES": 32 * 2**20 // 20,
        "HARNESS_MAX_XACRO_DOM_WORK": 50_000_000 // 20,
        "HARNESS_MAX_XACRO_DEPTH": 100 // 5,
    }.items():
        monkeypatch.setenv(variable, str(value))
    expansion = expand_xacro(MULTI_ARM, {"arm_prefixes": "['west','east']", "ros2_control": "true"})
    assert expansion.urdf.count(b"<link ") > 20


def test_an_include_of_a_device_is_refused(tmp_path):
    path = tmp_path / "device.urdf.xacro"
    path.write_text(f'{HEAD}<xacro:include filename="/dev/zero"/></robot>')
    with pytest.raises(XMLError) as caught:
        expand_xacro(path)
    assert str(caught.value) == "/dev/zero: not a regular file (xacro includes only files)"
