"""``harness demo`` end to end, as a user runs it."""

from __future__ import annotations

import re
import subprocess
import sys


def test_harness_demo_reports_identical_hashes_and_box_contacts():
    result = subprocess.run(
        [sys.executable, "-m", "harness", "demo"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    out = result.stdout
    blocks = {
        b.split()[0]: b for b in re.split(r"\n(?=(?:kinematic|position|velocity|effort) )", out)
    }
    for mode in ("kinematic", "position", "velocity", "effort"):
        block = blocks[mode].split("\n\n", 1)[0]
        assert "2500 steps" in block
        assert "identical" in block
        hashes = re.findall(r"run [12] sha256 ([0-9a-f]{64})", block)
        assert len(hashes) == 2
        assert hashes[0] == hashes[1]
        assert re.search(r"contact \w+ - box: first step \d+", block), block
    assert "state streams: identical in every mode" in out
