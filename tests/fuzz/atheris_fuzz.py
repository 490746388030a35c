"""Coverage-guided fuzzing with atheris (libFuzzer) over the targets of fuzzlib.py.

python tests/fuzz/atheris_fuzz.py TARGET [libFuzzer options, e.g. -max_total_time=60]

TARGET: frames, urdf, sdf, scenario, recording or xacro (xacrofuzz.py; the ROS xacro package
is instrumented too). The seed input is written to a fresh
corpus folder first. An exception other than the target's documented HarnessError subclass is
a crash: libFuzzer stops and writes the input to ``crash-<sha1>`` (make it a regression test).
Not part of ``make test`` (atheris is optional: ``pip install atheris``).
"""

from __future__ import annotations

import contextlib
import sys
import tempfile
from pathlib import Path

import atheris

with atheris.instrument_imports(include=["harness"]):
    import fuzzlib

with atheris.instrument_imports(include=["harness", "xacro"]):
    import xacro  # noqa: F401 - imported lazily by harness: instrumented here
    import xacrofuzz


def all_targets() -> dict[str, fuzzlib.Target]:
    """fuzzlib's targets and the xacro one."""
    return {**fuzzlib.targets(), "xacro": xacrofuzz.target()}


def main() -> None:
    targets = all_targets()
    if len(sys.argv) < 2 or sys.argv[1] not in targets:
        sys.exit(f"usage: atheris_fuzz.py {{{','.join(targets)}}} [libFuzzer options]")
    name = sys.argv.pop(1)
    function, allowed, seed = targets[name]
    corpus = Path(tempfile.mkdtemp(prefix=f"corpus-{name}-"))
    (corpus / "seed").write_bytes(seed)

    def one_input(data: bytes) -> None:
        with contextlib.suppress(allowed):
            function(data)

    atheris.Setup([*sys.argv, f"-max_len={max(4096, 2 * len(seed))}", str(corpus)], one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
