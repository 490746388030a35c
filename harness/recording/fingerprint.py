"""The platform fingerprint: what, besides the recorded inputs, can change the last bits of a
simulation, recorded in the ``harness`` metadata under ``fingerprint`` (JSON, schema below)
and compared by ``harness replay``, ``harness diff`` and the pytest golden check.

The same MuJoCo version gives different last bits on different machines (MuJoCo on CPUs with
and without AVX-512: google-deepmind/mujoco#2659). What decides them is which code runs:

- ``simd``: the CPU features code dispatches on at run time. ``fma`` and ``avx2``: glibc's
  libm picks its FMA/AVX2 variants of ``exp``, ``log``, ``pow``, ``sin``, ``cos`` (which
  MuJoCo's C code calls) by them; ``avx512f``/``cd``/``bw``/``dq``/``vl``: numpy's
  ``X86_V4``/``AVX512_SKX`` loops and OpenBLAS's SkylakeX kernels; ``avx``, ``f16c``,
  ``sse4_2``: numpy's ``X86_V3``/``X86_V2`` baselines (MuJoCo's x86 wheels need ``avx``);
  ``asimd``, ``sve``, ``sve2``: their ARM counterparts. Other flags (virtualisation, power,
  crypto) change no floating-point result and are left out, so two CPUs of one generation
  compare equal.
- ``mujoco``: its version and the wheel build (tag) it came from;
- ``numpy``: its version and the SIMD targets it dispatches to on this CPU; ``blas``: the
  BLAS numpy was built with, its version and the kernel set (core) it chose here;
- ``machine``, ``os``, ``libc``: the architecture, the system and the C library (its
  ``libm``) version.

``cpu`` (the model name) is recorded for people, not compared: what it changes, it changes
through the features and kernels above. The fingerprint is read once per process (Linux:
``/proc/cpuinfo``; elsewhere the features numpy detected at run time).

Schema 1, every value a string except ``simd`` (a sorted list)::

    {"schema": 1, "cpu": "...", "machine": "x86_64", "os": "linux", "libc": "glibc 2.36",
     "simd": ["avx", "avx2", "f16c", "fma", "sse4_2"], "mujoco": "4.0.0 (cp311-...)",
     "numpy": "2.4.6 (X86_V3)", "blas": "scipy-openblas 0.3.31 (Haswell)"}
"""

from __future__ import annotations

import ctypes
import glob
import json
import os
import platform
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from functools import cache
from importlib.metadata import PackageNotFoundError, distribution
from typing import Any, Final, NamedTuple

__all__ = [
    "COMPARED",
    "FINGERPRINT_KEY",
    "FINGERPRINT_SCHEMA",
    "SIMD_FLAGS",
    "Fingerprint",
    "PlatformComparison",
    "compare_fingerprints",
    "platform_fingerprint",
    "recorded_fingerprint",
]

FINGERPRINT_KEY: Final = "fingerprint"
FINGERPRINT_SCHEMA: Final = 1

# name in the fingerprint (the /proc/cpuinfo spelling) -> numpy's run-time feature name
SIMD_FLAGS: Final = {
    "sse4_2": "SSE42",
    "avx": "AVX",
    "f16c": "F16C",
    "fma": "FMA3",
    "avx2": "AVX2",
    "avx512f": "AVX512F",
    "avx512cd": "AVX512CD",
    "avx512bw": "AVX512BW",
    "avx512dq": "AVX512DQ",
    "avx512vl": "AVX512VL",
    "asimd": "ASIMD",
    "sve": "SVE",
    "sve2": "SVE2",
}
"""The CPU features that decide floating-point code paths (see the module docstring)."""

COMPARED: Final = ("machine", "os", "libc", "simd", "mujoco", "numpy", "blas")
"""The parts two fingerprints must share for a bit-exact claim (``cpu`` is not one)."""


@dataclass(frozen=True)
class Fingerprint:
    """What can change the last bits of a run on this platform (the module docstring)."""

    cpu: str
    machine: str
    os: str
    libc: str
    simd: tuple[str, ...]
    mujoco: str
    numpy: str
    blas: str

    def to_json(self) -> str:
        """The metadata value: schema 1 JSON, keys sorted."""
        return json.dumps({"schema": FINGERPRINT_SCHEMA, **asdict(self)}, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> Fingerprint:
        """Parse a metadata value; :class:`ValueError` naming what is wrong."""
        try:
            raw = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"not JSON ({exc.msg} at character {exc.pos})") from None
        if not isinstance(raw, dict):
            raise ValueError("not a JSON object")
        if raw.get("schema") != FINGERPRINT_SCHEMA:
            raise ValueError(f"schema {raw.get('schema')!r}, this harness reads schema 1")
        values: dict[str, Any] = {}
        for name in cls.__dataclass_fields__:
            if name not in raw:
                raise ValueError(f"no {name!r}")
            value = raw[name]
            if name == "simd":
                if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                    raise ValueError(f"'simd' is {value!r}, not a list of strings")
                values[name] = tuple(sorted(value))
            elif not isinstance(value, str):
                raise ValueError(f"{name!r} is {value!r}, not a string")
            else:
                values[name] = value
        return cls(**values)

    def part(self, name: str) -> str:
        """One part as text (``simd`` space-separated, ``none`` when empty)."""
        value = getattr(self, name)
        return (" ".join(value) or "none") if isinstance(value, tuple) else str(value)


class PlatformComparison(NamedTuple):
    """Two fingerprints compared: ``same`` (``None``: one side has none) and ``text``, what
    differs (``"simd: avx512f only in A; numpy: ..."``) or which side has none."""

    same: bool | None
    text: str


def compare_fingerprints(
    a: Fingerprint | None, b: Fingerprint | None, labels: tuple[str, str] = ("in A", "in B")
) -> PlatformComparison:
    """Compare the :data:`COMPARED` parts of ``a`` and ``b``; ``labels`` say where each is
    (``"in the recording"``, ``"here"``)."""
    missing = [label for label, f in zip(labels, (a, b), strict=True) if f is None]
    if a is None or b is None:
        return PlatformComparison(None, f"no platform fingerprint {' and '.join(missing)}")
    parts: list[str] = []
    for name in COMPARED:
        if getattr(a, name) == getattr(b, name):
            continue
        if name == "simd":
            only = [(sorted(set(x.simd) - set(y.simd)), label)
                    for x, y, label in ((a, b, labels[0]), (b, a, labels[1]))]  # fmt: skip
            parts.append(
                "simd: " + ", ".join(f"{' '.join(o)} only {label}" for o, label in only if o)
            )
        else:
            parts.append(f"{name}: {a.part(name)} {labels[0]}, {b.part(name)} {labels[1]}")
    if not parts:
        return PlatformComparison(True, "")
    if a.cpu != b.cpu:
        parts.append(f"cpu: {a.cpu} {labels[0]}, {b.cpu} {labels[1]}")
    return PlatformComparison(False, "; ".join(parts))


def recorded_fingerprint(metadata: Mapping[str, str], where: str = "") -> Fingerprint | None:
    """The fingerprint a recording's metadata holds, ``None`` for one made before harness
    recorded it; a malformed one raises :class:`ValueError` naming the key (and ``where``)."""
    text = metadata.get(FINGERPRINT_KEY)
    if text is None:
        return None
    try:
        return Fingerprint.from_json(text)
    except ValueError as exc:
        prefix = f"{where}: " if where else ""
        raise ValueError(f"{prefix}metadata {FINGERPRINT_KEY!r}: {exc}") from None


@cache
def platform_fingerprint() -> Fingerprint:
    """This process's platform (read once per process)."""
    cpu, flags = _cpuinfo()
    libc, libc_version = platform.libc_ver()
    return Fingerprint(
        cpu=cpu or platform.processor() or "unknown",
        machine=platform.machine() or "unknown",
        os=sys.platform,
        libc=f"{libc} {libc_version}".strip() or "unknown",
        simd=tuple(sorted(flags if flags is not None else _numpy_features())),
        mujoco=_mujoco(),
        numpy=_numpy(),
        blas=_blas(),
    )


def _cpuinfo() -> tuple[str, set[str] | None]:
    """The CPU model and the :data:`SIMD_FLAGS` it has, from ``/proc/cpuinfo`` (Linux);
    ``("", None)`` where there is none."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            text = f.read(1 << 20)
    except OSError:
        return "", None
    model = ""
    flags: set[str] | None = None
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key in ("model name", "cpu model", "hardware") and not model:
            model = " ".join(value.split())
        elif key in ("flags", "features") and flags is None:  # x86, ARM
            flags = set(value.split()) & set(SIMD_FLAGS)
        if model and flags is not None:
            break
    return model, flags


def _numpy_features() -> set[str]:
    import importlib

    found: dict[str, bool] = {}
    for module in ("numpy._core._multiarray_umath", "numpy.core._multiarray_umath"):
        try:
            found = dict(getattr(importlib.import_module(module), "__cpu_features__", {}))
        except ImportError:  # numpy 2 / numpy 1 spelling
            continue
        break
    return {name for name, numpy_name in SIMD_FLAGS.items() if found.get(numpy_name)}


def _wheel_tag(*names: str) -> str:
    for name in names:
        try:
            text = distribution(name).read_text("WHEEL") or ""
        except PackageNotFoundError:
            continue
        tags = [
            line.split(":", 1)[1].strip() for line in text.splitlines() if line.startswith("Tag:")
        ]
        if tags and tags[0] != "py3-none-any":
            return tags[0]
    return "unknown build"


def _mujoco() -> str:
    import mujoco

    return f"{mujoco.__version__} ({_wheel_tag('mujoco-core', 'mujoco')})"


def _numpy_config() -> dict[str, Any]:
    import numpy as np

    try:
        config = np.show_config(mode="dicts")
    except TypeError:  # numpy < 1.26: no mode
        return {}
    return dict(config) if isinstance(config, dict) else {}


def _numpy() -> str:
    import numpy as np

    simd = _numpy_config().get("SIMD Extensions", {}).get("found") or []
    return f"{np.__version__} ({' '.join(str(s) for s in simd) or 'baseline'})"


def _blas() -> str:
    blas = _numpy_config().get("Build Dependencies", {}).get("blas", {})
    name = f"{blas.get('name', 'unknown')} {blas.get('version', '')}".strip()
    core = _openblas_core()
    return f"{name} ({core})" if core else name


def _openblas_core() -> str:
    """The kernel set an OpenBLAS built for several CPUs (``DYNAMIC_ARCH``) chose here, from
    the library numpy loaded (threadpoolctl's answer when it is installed)."""
    try:
        from threadpoolctl import threadpool_info  # type: ignore[import-not-found]
    except ImportError:
        pass
    else:
        for pool in threadpool_info():
            if pool.get("internal_api") == "openblas" and pool.get("architecture"):
                return str(pool["architecture"])
    import numpy as np

    folder = os.path.join(os.path.dirname(os.path.dirname(np.__file__)), "numpy.libs")
    for path in sorted(glob.glob(os.path.join(folder, "*openblas*"))):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
                       "openblas_get_corename64_", "openblas_get_corename"):  # fmt: skip
            function = getattr(lib, symbol, None)
            if function is not None:
                function.restype = ctypes.c_char_p
                value = function()
                return value.decode("ascii", "replace") if value else ""
    return ""
