"""ros2_control_demos (vendored at ``tests/data/controllers/ros2_control_demos``, commit
0d9df42) as its launch files start each example: the description package's xacro with its
arguments, the controllers YAML with the launch file's ``update_rate`` and ``$(var ...)``
arguments, and only the controllers its spawners name."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from harness import Session
from harness.controllers import ControllersConfig, load_controllers
from harness.models import load_robot
from harness.testing import Subscription

DEMOS = Path(__file__).resolve().parents[2] / "data" / "controllers" / "ros2_control_demos"
PACKAGES = {
    **{
        f"ros2_control_demo_example_{n}": DEMOS / f"example_{n}" / "description"
        for n in range(1, 18)
    },
    "ros2_control_demo_description": DEMOS / "ros2_control_demo_description",
}
"""Each example package installs its ``description/`` folder as its share folder (CMakeLists)."""


def urdf(n: int) -> Path:
    """The example's robot description (its only ``description/urdf/*.xacro``)."""
    (path,) = (DEMOS / f"example_{n}" / "description" / "urdf").glob("*.xacro")
    return path


def config_path(n: int, name: str) -> Path:
    """``example_<n>/bringup/config/<name>``."""
    return DEMOS / f"example_{n}" / "bringup" / "config" / name


def controllers(
    n: int,
    name: str,
    spawned: Sequence[str] | None = None,
    update_rate: float | None = None,
    args: Mapping[str, str] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> ControllersConfig:
    """The example's controllers YAML as its launch file loads it: ``update_rate`` where the
    launch file sets the manager's (a parameter of ``ros2_control_node``), ``args`` for its
    ``$(var ...)``, ``extra`` parameters (a spawner's remapping: ``cmd_vel_topic``...) and
    only the ``spawned`` controllers (every one when None)."""
    sources: list[Any] = [config_path(n, name)]
    if update_rate is not None:
        sources.append({"controller_manager": {"ros__parameters": {"update_rate": update_rate}}})
    if extra is not None:
        sources.append(extra)
    config = load_controllers(sources, args=args)
    if spawned is not None:
        specs = tuple(s for s in config.controllers if s.name in spawned)
        assert {s.name for s in specs} == set(spawned)
        config = dataclasses.replace(config, controllers=specs)
    return config


def session(n: int, config: ControllersConfig, **keywords: Any) -> Session:
    """A lockstep session of example ``n``'s robot with ``config`` (its hardware plugin, a
    vendor's or a mock, is replaced by the simulation: that warning is expected)."""
    load = {k: keywords.pop(k) for k in ("base", "control", "robot_args") if k in keywords}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(urdf(n), packages=PACKAGES, **load)
    return Session(robot, controllers=config, **keywords)


def latest(states: Subscription, joints: Sequence[str], field: str = "position") -> list[float]:
    """The joints' latest ``field`` on a ``/joint_states`` subscription."""
    msg = states.messages[-1]
    by_name = dict(zip(msg["name"], msg[field], strict=True))
    return [float(by_name[j]) for j in joints]


def command(values: Sequence[float]) -> dict[str, Any]:
    """A ``std_msgs/msg/Float64MultiArray``."""
    return {"layout": {"dim": [], "data_offset": 0}, "data": [float(v) for v in values]}


def is_nan(value: Any) -> bool:
    """A NaN as it arrives over the bridge (JSON has none: null, or the float)."""
    return value is None or (isinstance(value, float) and math.isnan(value))
