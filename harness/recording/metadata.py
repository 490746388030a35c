"""The recording's ``harness`` metadata record and the names and media types of its
attachments."""

from __future__ import annotations

import functools
import os
import platform
import sys
from collections.abc import Mapping
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from harness._version import __version__
from harness.recording.errors import RecordingWriteError
from harness.recording.fingerprint import FINGERPRINT_KEY, platform_fingerprint
from harness.recording.layout import FORMAT_VERSION, METADATA_REQUIRED

__all__ = ["build_metadata", "definitions_text", "media_type", "package_version"]

_MEDIA_TYPES = {
    ".xml": "application/xml",
    ".urdf": "application/xml",
    ".sdf": "application/xml",
    ".xacro": "application/xml",
    ".srdf": "application/xml",
    ".yaml": "application/yaml",
    ".yml": "application/yaml",
    ".json": "application/json",
    ".toml": "application/toml",
    ".txt": "text/plain",
    ".msg": "text/plain",
}
# Keys the recorder itself writes; a caller giving one is an error.
_RESERVED = (
    "format_version",
    "harness_version",
    "mujoco_version",
    "numpy_version",
    "python_version",
    "platform",
    "state_every",
    "compression",
    FINGERPRINT_KEY,
)


@functools.cache
def package_version(name: str) -> str:
    """An installed distribution's version (``"unknown"`` when it is not installed); read once
    per process (``importlib.metadata`` scans the path: about 10 ms a recording otherwise)."""
    try:
        return version(name)
    except PackageNotFoundError:
        return "unknown"


def build_metadata(
    metadata: Mapping[str, str], *, state_every: int, compression: str
) -> dict[str, str]:
    """The ``harness`` metadata record: the caller's keys (validated) plus versions, platform
    and the platform fingerprint (:mod:`harness.recording.fingerprint`)."""
    for key, value in metadata.items():
        if not isinstance(key, str) or not isinstance(value, str):
            raise RecordingWriteError(
                f"metadata: key {key!r} must map a string to a string, got {type(value).__name__}"
            )
        if key in _RESERVED:
            raise RecordingWriteError(f"metadata: key {key!r} is written by the recorder")
    missing = [key for key in METADATA_REQUIRED if key not in metadata]
    if missing:
        raise RecordingWriteError(
            f"metadata: missing required key {missing[0]!r} (required: "
            f"{', '.join(METADATA_REQUIRED)})"
        )
    try:
        timestep = float(metadata["timestep"])
    except ValueError:
        timestep = -1.0
    if not timestep > 0:
        raise RecordingWriteError(
            f"metadata: 'timestep' must be a positive number of seconds, "
            f"got {metadata['timestep']!r}"
        )
    out = dict(metadata)
    timestep_ns = out.setdefault("timestep_ns", str(round(timestep * 1e9)))
    if not timestep_ns.isdigit() or int(timestep_ns) <= 0:
        raise RecordingWriteError(
            f"metadata: 'timestep_ns' must be a positive integer, got {timestep_ns!r}"
        )
    out.update(
        format_version=str(FORMAT_VERSION),
        harness_version=__version__,
        mujoco_version=package_version("mujoco"),
        numpy_version=np.__version__,
        python_version=platform.python_version(),
        platform=f"{sys.platform} {platform.machine()} {platform.platform()}",
        state_every=str(state_every),
        compression=compression,
        **{FINGERPRINT_KEY: platform_fingerprint().to_json()},
    )
    return dict(sorted(out.items()))


def media_type(name: str) -> str:
    """The media type of an attachment, by its name's extension."""
    return _MEDIA_TYPES.get(os.path.splitext(name)[1].lower(), "application/octet-stream")


def definitions_text() -> bytes:
    """Every ``harness_msgs`` definition as text (the attachment of a run given none)."""
    from harness.msgs import message_definitions

    parts = [f"# {name}\n{text}" for name, text in message_definitions().items()]
    return "\n".join(parts).encode("utf-8")
