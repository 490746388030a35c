"""Metadata and attachments of a run, built from a loaded robot and its scenario."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from typing import Any, NamedTuple, Protocol

from harness.recording.layout import (
    ATTACHMENT_MODEL,
    ATTACHMENT_MODEL_BINARY,
    ATTACHMENT_SCENARIO,
    ATTACHMENT_SOURCE_PREFIX,
)

__all__ = ["LoadedRobotLike", "RunDescription", "describe_run"]


class LoadedRobotLike(Protocol):
    """What :func:`describe_run` reads of ``harness.models.LoadedRobot``."""

    @property
    def name(self) -> str: ...
    @property
    def mjcf(self) -> str: ...
    @property
    def mjb(self) -> bytes: ...
    @property
    def sources(self) -> Mapping[str, bytes]: ...
    @property
    def sha256(self) -> str: ...
    @property
    def control(self) -> Mapping[str, Any]: ...
    @property
    def model(self) -> Any: ...


class RunDescription(NamedTuple):
    """``Recorder(path, metadata=d.metadata, attachments=d.attachments)``."""

    metadata: dict[str, str]
    attachments: dict[str, bytes]


def _integrator_name(value: int) -> str:
    import mujoco

    return str(mujoco.mjtIntegrator(int(value)).name).removeprefix("mjINT_")


def describe_run(
    robot: LoadedRobotLike,
    *,
    seed: int = 0,
    scenario: str | bytes | None = None,
    scenario_name: str = "scenario.yaml",
    extra: Mapping[str, str] | None = None,
) -> RunDescription:
    """The ``harness`` metadata (timestep, integrator, seed, model SHA-256, control modes,
    robot name) and the attachments (the exact compiled model as MJB, the compiled MJCF for
    reading, source files under ``source/``, the
    scenario under ``scenario/<scenario_name>``) of a run of ``robot``."""
    timestep = float(robot.model.opt.timestep)
    control = {str(joint): str(mode) for joint, mode in robot.control.items()}
    metadata = {
        "robot": robot.name,
        "timestep": repr(timestep),
        "timestep_ns": str(round(timestep * 1e9)),
        "integrator": _integrator_name(robot.model.opt.integrator),
        "seed": str(seed),
        "model_sha256": robot.sha256,
        "control_modes": json.dumps(control, sort_keys=True),
        **(extra or {}),
    }
    attachments = {
        ATTACHMENT_MODEL_BINARY: bytes(robot.mjb),
        ATTACHMENT_MODEL: robot.mjcf.encode("utf-8"),
    }
    for name, blob in sorted(robot.sources.items()):
        attachments[ATTACHMENT_SOURCE_PREFIX + name.replace(os.sep, "/").lstrip("/")] = bytes(blob)
    if scenario is not None:
        text = scenario.encode("utf-8") if isinstance(scenario, str) else scenario
        attachments[f"{ATTACHMENT_SCENARIO}/{scenario_name}"] = text
    return RunDescription(metadata, attachments)
