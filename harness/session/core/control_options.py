"""The ``controllers=`` option of a session: its forms, the default set resolved for a robot,
the robots a base controller drives, and its recording metadata (the half of
:mod:`harness.session.core.control` that runs before a core exists)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from harness.controllers import (
    ControllersConfig,
    ControllersConfigError,
    default_controllers,
    load_controllers,
)
from harness.models import LoadedRobot, LoadedWorld

__all__ = [
    "CONFIG_DEFAULT",
    "CONFIG_NONE",
    "ControllersOption",
    "base_driven",
    "controllers_from_metadata",
    "controllers_metadata",
    "controllers_option",
    "resolve_default",
    "with_drive_plugins",
]

CONFIG_DEFAULT = "default"
CONFIG_NONE = "none"


ControllersOption = (
    ControllersConfig
    | str
    | Path
    | Mapping[str, Any]
    | Sequence[str | Path | Mapping[str, Any]]
    | bool
    | None
)
"""What ``controllers=`` takes: a controllers YAML (path, text or parsed mapping) or several
(merged in order), a :class:`ControllersConfig`, None/True (the default set) or
False/``"none"`` (no controllers)."""


def controllers_option(
    value: ControllersOption, args: Mapping[str, Any] | None = None
) -> ControllersConfig | str:
    """The core's form of a ``controllers=`` value (a YAML is read here, its ``$(var NAME)``
    expanded from ``args``: ``controllers_args=``)."""
    if value is None or value is True or value == CONFIG_DEFAULT:
        return CONFIG_DEFAULT
    if value is False or value == CONFIG_NONE:
        return CONFIG_NONE
    if isinstance(value, ControllersConfig):
        return value
    if isinstance(value, str | Path | Mapping):
        return load_controllers(value, args)
    if isinstance(value, list | tuple) and all(isinstance(v, str | Path | Mapping) for v in value):
        return load_controllers(value, args)
    raise ControllersConfigError(
        "controllers must be a YAML file, YAML text, a mapping, a list of them, True or False, "
        f"not {value!r}"
    )


def resolve_default(
    config: ControllersConfig | str, robot: LoadedRobot | LoadedWorld
) -> ControllersConfig | str:
    """``"default"`` for one robot resolved to its default set, so that a recording holds the
    exact configuration (a world's robots each resolve their own at run time)."""
    if config != CONFIG_DEFAULT or not isinstance(robot, LoadedRobot):
        return config
    # a single robot's controllable joints, in the simulation's order (its control order)
    default = default_controllers(list(robot.control), robot.control)
    return with_drive_plugins(default, robot)


def with_drive_plugins(config: ControllersConfig, robot: LoadedRobot) -> ControllersConfig:
    """``config`` plus a diff drive controller per drive plugin the robot's file declares."""
    from harness.controllers import robot_controllers

    return robot_controllers(config, robot.sources)


def base_driven(
    config: ControllersConfig | str, loaded: LoadedRobot | LoadedWorld, namespace: str
) -> tuple[str, ...]:
    """The namespaces of the robots a base controller (diff drive, planar) drives under
    ``config`` (``namespace``: a single robot's)."""
    from harness.controllers import BASE_CONTROLLER_TYPES, robot_controllers

    if config == CONFIG_NONE:
        return ()
    robots = (
        [(namespace, loaded.sources)]
        if isinstance(loaded, LoadedRobot)
        else [(view.namespace, view.sources) for view in loaded.robots]
    )
    out: list[str] = []
    for space, sources in robots:
        own = robot_controllers(ControllersConfig(), sources) if isinstance(config, str) else config
        if any(spec.type in BASE_CONTROLLER_TYPES for spec in own.controllers):
            out.append(space)
    return tuple(out)


def controllers_metadata(config: ControllersConfig | str) -> str:
    """The recording metadata text of a session's controllers option."""
    return config if isinstance(config, str) else config.to_json()


def controllers_from_metadata(text: str | None) -> ControllersConfig | str:
    """The controllers option of a recorded session (a recording without the key had none)."""
    if text is None or text == CONFIG_NONE:
        return CONFIG_NONE
    if text == CONFIG_DEFAULT:
        return CONFIG_DEFAULT
    return ControllersConfig.from_json(text)
