"""Shared paths and helpers of the scenario tests.

Imported as ``tests.scenario.scenario_testlib`` (pytest puts the project root on ``sys.path``),
so spawned worker processes, which inherit ``sys.path``, can unpickle the runners defined here.
"""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "scenario"
EXAMPLES = ROOT / "scenarios"
CLIENT = DATA / "clients" / "client.py"


def process_gone(pid: int) -> bool:
    """True when ``pid`` no longer runs (absent, or a zombie awaiting its reaper)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return True
    return stat[stat.rfind(")") + 2] in "ZX"


def gone_runner(spec):
    """An IterationRunner whose worker process dies mid-iteration."""
    os._exit(17)
