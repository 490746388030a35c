"""Metadata and attachments of a run, built from a loaded robot (or a world of several robots)
and its scenario.

A world (``harness.models.LoadedWorld``) adds two metadata keys, JSON, from which replay
rebuilds the same world (``harness.replay.source.rebuild_run``):

- ``robots``: one object per robot, in the world's order: ``namespace``, ``source`` (its
  ``source/`` attachment, e.g. ``"model/left/demo_arm.urdf"``), ``pose`` (the placement used,
  ``[x, y, z, qw, qx, qy, qz]``, or null for the world origin), ``control`` (its own joint ->
  mode), ``srdf`` (attachment or null), ``self_collision`` (policy, origin, ignored link
  pairs with their reason), ``base`` (fixed or floating) and, when the run knows the
  robot's ``RobotSpec``
  (``specs``), its ``initial_positions``, ``gains``, ``visuals``, ``repair_inertia`` and
  ``strict``;
- ``objects``: the primitives added to the world (``name``, ``shape``, ``size``, ``pose``,
  ``mass``, ``rgba``).

``control_modes`` then holds every robot's joints by MuJoCo (prefixed) name.

A xacro robot (see ``harness.models.xacro.expand``) adds ``robot_xacro`` (the entry file as the user
named it) and ``robot_args`` (JSON object of its arguments) to the metadata, or ``xacro`` and
``robot_args`` to its entry in ``robots``; its expanded URDF is the ``source/model/...``
attachment, the files the expansion read are ``source/xacro/...`` and the meshes it names
``source/package/<pkg>/...``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple, Protocol

from harness.recording.layout import (
    ATTACHMENT_MODEL,
    ATTACHMENT_MODEL_BINARY,
    ATTACHMENT_SCENARIO,
    ATTACHMENT_SOURCE_PREFIX,
)
from harness.recording.meshes import mesh_attachments, visual_only_attachments
from harness.recording.sourcelinks import link_sources

__all__ = ["LoadedRobotLike", "RunDescription", "describe_run", "world_metadata"]


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


def _pose(pose: Any) -> list[float] | None:
    if pose is None:
        return None
    values = pose.as_list() if hasattr(pose, "as_list") else list(pose)
    return [float(v) for v in values]


def _placement(pose: Any) -> list[float] | None:
    values = _pose(pose)
    return None if values is None or values == [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0] else values


def world_metadata(
    world: Any, specs: Sequence[Any] | None = None, objects: Sequence[Any] = ()
) -> dict[str, str]:
    """The ``robots`` and ``objects`` metadata of a world (see the module docstring):
    ``world`` a ``LoadedWorld``, ``specs`` the ``RobotSpec`` each robot was loaded from
    (same order) when known, ``objects`` the ``WorldObject``\\ s added."""
    robots: list[dict[str, Any]] = []
    for index, view in enumerate(world.robots):
        sources = sorted(view.sources)
        entry: dict[str, Any] = {
            "namespace": view.namespace,
            "source": next((n for n in sources if n.startswith("model/")), None),
            "pose": _placement(view.placement),
            "control": {str(j): str(m) for j, m in view.control.items()},
            "srdf": next((n for n in sources if n.startswith("srdf/")), None),
            **_xacro_entry(view),
        }
        # issue 14: which self-collision pairs were ignored and why, and the base kind
        report = getattr(view, "self_collision", None)
        if report is not None:
            entry["self_collision"] = report.as_dict()
        entry["base"] = str(getattr(view, "base", "fixed"))
        if specs is not None and index < len(specs):
            spec = specs[index]
            entry["initial_positions"] = {
                str(j): float(v) for j, v in dict(spec.initial_positions).items()
            }
            entry["gains"] = (
                None if spec.gains is None else {str(j): float(v) for j, v in spec.gains.items()}
            )
            entry["visuals"] = bool(spec.visuals)
            entry["repair_inertia"] = bool(spec.repair_inertia)
            entry["strict"] = bool(getattr(spec, "strict", False))
        robots.append(entry)
    listed = [
        {
            "name": obj.name,
            "shape": obj.shape,
            "size": [float(v) for v in obj.size],
            "pose": _pose(obj.pose),
            "mass": None if obj.mass is None else float(obj.mass),
            "rgba": None if obj.rgba is None else [float(v) for v in obj.rgba],
            # only when given: the metadata of a run without it stays what it was
            **({} if obj.friction is None else {"friction": [float(v) for v in obj.friction]}),
        }
        for obj in objects
    ]
    return {
        "robots": json.dumps(robots, sort_keys=True),
        "objects": json.dumps(listed, sort_keys=True),
    }


def _xacro_entry(robot: Any) -> dict[str, Any]:
    origin = getattr(getattr(robot, "description", None), "xacro", None)
    if origin is None:
        return {}
    return {
        "xacro": str(origin.source),
        "robot_args": {str(k): str(v) for k, v in origin.args.items()},
    }


def _xacro_metadata(robot: Any) -> dict[str, str]:
    entry = _xacro_entry(robot)
    if not entry:
        return {}
    return {
        "robot_xacro": entry["xacro"],
        "robot_args": json.dumps(entry["robot_args"], sort_keys=True),
    }


def _robot_metadata(robot: Any) -> dict[str, str]:
    """A single robot's self-collision policy (with the ignored pairs) and base kind (issue
    14; a world has them per robot in ``robots``)."""
    report = getattr(robot, "self_collision", None)
    if report is None or hasattr(robot, "robots"):
        return {}
    return {
        "self_collision": json.dumps(report.as_dict(), sort_keys=True),
        "base": str(getattr(robot, "base", "fixed")),
    }


def describe_run(
    robot: LoadedRobotLike,
    *,
    seed: int = 0,
    scenario: str | bytes | None = None,
    scenario_name: str = "scenario.yaml",
    extra: Mapping[str, str] | None = None,
    specs: Sequence[Any] | None = None,
    objects: Sequence[Any] = (),
) -> RunDescription:
    """The ``harness`` metadata (timestep, integrator, seed, model SHA-256, control modes,
    robot name, a single robot's ``self_collision`` and ``base``, ``mesh_collision``; for a
    world its ``robots``
    and ``objects``, see :func:`world_metadata`) and the attachments (the exact compiled
    model as MJB, the compiled MJCF for reading, source files under ``source/``, with the
    meshes a URDF references (:func:`harness.recording.meshes.mesh_attachments`), the
    scenario under ``scenario/<scenario_name>``) of a run of ``robot`` (a ``LoadedRobot`` or
    a ``LoadedWorld``)."""
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
        **(world_metadata(robot, specs, objects) if hasattr(robot, "robots") else {}),
        **_xacro_metadata(robot),
        **_robot_metadata(robot),
        # issue 33: how non-convex collision meshes collided (a recording without the key
        # is older than decomposition: its meshes collided as their hulls)
        "mesh_collision": str(getattr(robot, "mesh_collision", "hull")),
        **(extra or {}),
    }
    attachments = {
        ATTACHMENT_MODEL_BINARY: bytes(robot.mjb),
        ATTACHMENT_MODEL: robot.mjcf.encode("utf-8"),
    }
    for name, blob in sorted(robot.sources.items()):
        attachments[ATTACHMENT_SOURCE_PREFIX + name.replace(os.sep, "/").lstrip("/")] = bytes(blob)
    description = getattr(robot, "description", None)
    if description is not None and not hasattr(robot, "robots"):
        # The meshes a URDF references, so that a rebuild elsewhere finds them; without
        # visuals, not those only the visuals use (the model has no visual geom to rebuild).
        meshes = mesh_attachments(robot.sources, getattr(description, "source", None))
        for name, blob in meshes.items():
            attachments.setdefault(name, blob)
        if getattr(robot, "visuals", False):
            metadata["visuals"] = "true"
        else:
            for name in visual_only_attachments(robot.sources):
                attachments.pop(name, None)
    if scenario is not None:
        text = scenario.encode("utf-8") if isinstance(scenario, str) else scenario
        attachments[f"{ATTACHMENT_SCENARIO}/{scenario_name}"] = text
    return RunDescription(metadata, link_sources(attachments))
