"""``harness check-model``: the sanity report a user runs first on a robot."""

from harness.models.check.report import (
    HOLD_M,
    HOLD_RAD,
    HOLD_SECONDS,
    JointCheck,
    ModelCheck,
    StandCheck,
    check_loaded,
    check_model,
)

__all__ = [
    "HOLD_M",
    "HOLD_RAD",
    "HOLD_SECONDS",
    "JointCheck",
    "ModelCheck",
    "StandCheck",
    "check_loaded",
    "check_model",
]
