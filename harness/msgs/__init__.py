"""The ``harness_msgs`` interface definitions (``.msg``/``.srv`` files shipped in the package).

One source of truth for the recorder (CDR schemas), the rosbridge type registry and rosapi.
"""

from __future__ import annotations

from functools import cache
from importlib import resources

__all__ = ["PACKAGE", "definitions", "message_definitions", "service_definitions"]

PACKAGE = "harness_msgs"


def _read(kind: str, suffix: str) -> dict[str, str]:
    folder = resources.files(__name__) / PACKAGE / kind
    out: dict[str, str] = {}
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(suffix):
            out[f"{PACKAGE}/{kind}/{entry.name[: -len(suffix)]}"] = entry.read_text("utf-8")
    return out


@cache
def message_definitions() -> dict[str, str]:
    """``{"harness_msgs/msg/BridgeFrame": "<.msg text>", ...}``."""
    return _read("msg", ".msg")


@cache
def service_definitions() -> dict[str, str]:
    """``{"harness_msgs/srv/Step": "<.srv text>", ...}``."""
    return _read("srv", ".srv")


def definitions() -> dict[str, str]:
    """Every message and service definition, keyed by full type name."""
    return {**message_definitions(), **service_definitions()}
