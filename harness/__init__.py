"""harness: deterministic record-replay simulation tests for ROS robot software.

The public names are imported lazily so that ``import harness`` (and the pytest plugin)
stays cheap: MuJoCo, websockets and MCAP load only when first used.
"""

from __future__ import annotations

import importlib
from typing import Any

from harness._version import __version__
from harness.errors import HarnessError

__all__ = [
    "HarnessError",
    "RobotModel",
    "Scenario",
    "Session",
    "Simulation",
    "__version__",
    "load_robot",
]

_LAZY = {
    "RobotModel": "harness.models",
    "load_robot": "harness.models",
    "Simulation": "harness.sim",
    "Session": "harness.session",
    "Scenario": "harness.scenario",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'harness' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
