"""MJCF: a :class:`~harness.models.RobotModel` from a compiled model, and MJCF file references
confined before MuJoCo reads them.
"""

from harness.models.mjcf.describe import (
    description_from_model,
)

__all__ = [
    "description_from_model",
]
