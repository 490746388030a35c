"""The xacro fuzz target, its seed and a generator of xacro documents, shared by the hypothesis
tests (test_fuzz_xacro.py) and the atheris driver (atheris_fuzz.py ``xacro``).

The target expands a document with :func:`harness.models.xacro.expand.expand_xacro`: it works or
raises a ModelError (one line; the expansion limits among them), never anything else, and
never runs past the limits. :func:`raw_expansions` runs xacro's own expansion with and without
the harness's meter on the same file: the meter's splice must not change a byte of output.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from harness.models.files.limits import XACRO_LIMITS
from harness.models.xacro import expand as harness_xacro
from harness.models.xacro.meter import XacroMeter, metered

__all__ = ["XACRO_SEED", "fuzz_xacro", "raw_expansions", "target", "write"]

WORK = Path(tempfile.mkdtemp(prefix="harness-fuzz-xacro-"))
(WORK / "part.xacro").write_text(
    '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">'
    '<xacro:macro name="part" params="n"><link name="part_${n}"/></xacro:macro></robot>'
)

XACRO_SEED = b"""<?xml version="1.0"?>
<robot name="seed" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="wide" default="true"/>
  <xacro:property name="r" value="0.05"/>
  <xacro:property name="s" value="ab"/>
  <xacro:property name="d" value="${2*r}"/>
  <xacro:include filename="part.xacro"/>
  <xacro:include filename="missing.xacro" optional="true"/>
  <!-- a comment before a call -->
  <xacro:macro name="wheel" params="n x:=0 *origin">
    <link name="wheel_${n}"><visual><xacro:insert_block name="origin"/>
      <geometry><cylinder radius="${r}" length="${d}"/></geometry></visual></link>
    <joint name="j_${n}" type="continuous"><parent link="base"/><child link="wheel_${n}"/>
      <origin xyz="${x} 0 0"/></joint>
  </xacro:macro>
  <xacro:macro name="pair" params="p"><xacro:wheel n="${p}l" x="1"><origin/></xacro:wheel>
    <xacro:wheel n="${p}r"><origin xyz="0 1 0"/></xacro:wheel></xacro:macro>
  <link name="base${s+s}"/>
  <xacro:pair p="front"/>
  <xacro:if value="$(arg wide)"><xacro:pair p="rear"/></xacro:if>
  <xacro:unless value="${r > 1}"><xacro:part n="1"/></xacro:unless>
</robot>
"""


def write(name: str, data: bytes) -> Path:
    """``data`` as the file ``name`` in the fuzz folder (next to ``part.xacro``)."""
    path = WORK / name
    path.write_bytes(data)
    return path


def fuzz_xacro(data: bytes) -> None:
    """Expand a xacro file (the bytes as ``fuzz.urdf.xacro``) as ``load_robot`` would."""
    harness_xacro.expand_xacro(write("fuzz.urdf.xacro", data))


def target() -> tuple[Any, Any, bytes]:
    """``(function, the errors it may raise, seed)`` like fuzzlib.targets()'s entries."""
    from harness.errors import ModelError

    return fuzz_xacro, ModelError, XACRO_SEED


def _raw(path: Path, meter: XacroMeter | None) -> tuple[str, str | None]:
    """xacro's own expansion of ``path``: ``("ok", xml)`` or ``(exception type name, None)``."""
    import xacro

    with harness_xacro._LOCK:
        xacro.all_includes = []
        xacro.init_stacks(None)
        try:
            if meter is None:
                text = str(xacro.process_file(str(path)).toxml())
            else:
                with metered(xacro, meter):
                    text = str(xacro.process_file(str(path)).toxml())
        except Exception as exc:  # compared, not handled
            return type(exc).__name__, None
        finally:
            xacro.init_stacks(None)
            xacro.all_includes = []
    return "ok", text


def raw_expansions(path: Path) -> tuple[tuple[str, str | None], tuple[str, str | None]]:
    """(plain xacro, xacro under the harness's meter) on the same file."""
    return _raw(path, None), _raw(path, XacroMeter(XACRO_LIMITS))
