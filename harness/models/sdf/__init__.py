"""SDFormat 1.4-1.11 models and worlds: frame semantics, includes, nested models."""

from harness.models.sdf.build import build_spec
from harness.models.sdf.convert import (
    FREE_JOINT_SUFFIX,
    PlacedModel,
    SdfWorld,
    read_sdf,
    read_sdf_world,
    to_robot_model,
)
from harness.models.sdf.document import SdfDocument, load_document
from harness.models.sdf.errors import (
    SdfCycleError,
    SdfError,
    SdfFrameError,
    SdfIncludeError,
    SdfInertiaError,
    SdfStructureError,
    SdfSyntaxError,
    SdfVersionError,
    SdfWarning,
)

__all__ = [
    "FREE_JOINT_SUFFIX",
    "PlacedModel",
    "SdfCycleError",
    "SdfDocument",
    "SdfError",
    "SdfFrameError",
    "SdfIncludeError",
    "SdfInertiaError",
    "SdfStructureError",
    "SdfSyntaxError",
    "SdfVersionError",
    "SdfWarning",
    "SdfWorld",
    "build_spec",
    "load_document",
    "read_sdf",
    "read_sdf_world",
    "to_robot_model",
]
