"""The ``@pytest.mark.harness`` marker: its keys, the merge of a test's markers, the parse of
their values (one spelling each, from :mod:`harness.vocabulary`), and the control mode a session
runs in once the suite's ``--harness-actuation`` applies.

A wrong key or value fails the test with a one-line message naming it (``pytest.fail``).
This module imports only the standard library, pytest and :mod:`harness.vocabulary`.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

import pytest

from harness.vocabulary import Actuation, ControlMode

__all__ = [
    "check_keys",
    "first_robot_keys",
    "marker_keys",
    "marker_options",
    "one_mode",
    "parse_load_options",
    "parse_mode",
    "resolve_path",
    "suite_mode",
    "suite_robots",
]

_MARKER_OWN = frozenset(
    {
        "robot",
        "scenario",  # a scenario file (Session's scenario= is its text, attached)
        "collisions",
        "joint_limits",
        "connect",  # the marker's spelling of Session(connect_to=)
        "world",  # a Gazebo world as the map: the same option as scene (harness serve --world)
        "resume",  # continue a recording from a step (harness.resume)
    }
)
_NOT_MARKER = frozenset({"host", "port", "token", "record_to"})  # the plugin's own choice
_DYNAMIC = (ControlMode.POSITION, ControlMode.VELOCITY, ControlMode.EFFORT)
_SPEC_SPELLINGS = {"source": "robot", "control": "mode"}  # as Session(robot=, mode=) spells them


@functools.cache
def marker_keys() -> frozenset[str]:
    """The keys ``@pytest.mark.harness`` and ``harness_session_factory`` accept: the
    session's options fields (:data:`harness.session.options.SESSION_KEYWORDS`) but where
    the plugin decides (the free port, the recording path), and the marker's own keys."""
    from harness.session import SESSION_KEYWORDS

    return frozenset((set(SESSION_KEYWORDS) - _NOT_MARKER) | _MARKER_OWN)


@functools.cache
def first_robot_keys() -> Mapping[str, str]:
    """The marker keys that, with ``scenario=``, apply to the scenario's first robot, each
    -> the :class:`harness.models.RobotSpec` field it sets: every RobotSpec field that is a
    marker key (:func:`marker_keys`), ``source`` spelled ``robot`` and ``control`` spelled
    ``mode`` as ``Session`` spells them. A RobotSpec field that becomes a session option
    applies to the first robot without another edit."""
    from dataclasses import fields

    from harness.models.world.records import RobotSpec

    keys = marker_keys()
    spelled = ((_SPEC_SPELLINGS.get(f.name, f.name), f.name) for f in fields(RobotSpec))
    return MappingProxyType({key: name for key, name in spelled if key in keys})


def marker_options(item: pytest.Item) -> dict[str, Any]:
    """The merged ``harness`` markers (closest first wins); positional arg = robot."""
    options: dict[str, Any] = {}
    for mark in item.iter_markers("harness"):
        if len(mark.args) > 1:
            pytest.fail(
                f"{item.nodeid}: @pytest.mark.harness takes at most one positional argument "
                f"(the robot), got {len(mark.args)}",
                pytrace=False,
            )
        values = dict(mark.kwargs)
        if mark.args:
            values.setdefault("robot", mark.args[0])
        for key, value in values.items():
            options.setdefault(key, value)
    return options


def check_keys(where: str, options: Mapping[str, Any]) -> None:
    """Fail the test when ``options`` has a key the marker does not know."""
    known = marker_keys()
    unknown = sorted(set(options) - known)
    if unknown:
        pytest.fail(
            f"{where}: unknown harness option {unknown[0]!r} (known: {', '.join(sorted(known))})",
            pytrace=False,
        )


def parse_mode(mode: Any, where: str = "harness option 'mode'") -> Any:
    """A marker's ``mode`` (one mode or joint -> mode) with every spelling parsed
    (``dynamic`` is ``position``): :class:`~harness.vocabulary.ControlMode` members."""
    try:
        if isinstance(mode, Mapping):
            return {j: ControlMode.parse(m, f"{where}[{j!r}]") for j, m in mode.items()}
        return None if mode is None else ControlMode.parse(mode, where)
    except ValueError as exc:
        pytest.fail(str(exc), pytrace=False)


def parse_load_options(opts: dict[str, Any], where: str) -> None:
    """The marker's ``self_collision``, ``base``, ``clock``, ``kinematic_limits`` and
    ``mesh_collision`` parsed in place (one spelling, from :mod:`harness.vocabulary`); a wrong
    value fails the test naming it."""
    from harness.vocabulary import (
        ClockMode,
        LimitPolicy,
        MeshCollisionMode,
        RobotBase,
        SelfCollisionPolicy,
    )

    try:
        for key, vocabulary in (
            ("clock", ClockMode),
            ("kinematic_limits", LimitPolicy),
            ("mesh_collision", MeshCollisionMode),
        ):
            if opts.get(key) is not None:
                opts[key] = vocabulary.parse(opts[key], f"{where}: harness option {key!r}")
        if opts.get("self_collision") is not None:
            opts["self_collision"] = SelfCollisionPolicy.parse(
                opts["self_collision"], f"{where}: harness option 'self_collision'"
            ).value
        if opts.get("base") is not None:
            opts["base"] = RobotBase.parse(opts["base"], f"{where}: harness option 'base'").value
    except ValueError as exc:
        pytest.fail(str(exc), pytrace=False)
    if "strict" in opts and not isinstance(opts["strict"], bool):
        pytest.fail(f"{where}: harness option 'strict' must be true or false", pytrace=False)


def suite_mode(mode: Any, suite: Actuation | str | None) -> Any:
    """The control mode a session runs in: the test's ``mode`` (parsed: ``dynamic`` is
    ``position``) unless the suite's actuation (``--harness-actuation``) makes every joint
    kinematic, or every kinematic joint a position servo (``servo``)."""
    mode = parse_mode(mode)
    if suite is None:
        return mode if mode is not None else ControlMode.POSITION
    if Actuation.parse(suite, "--harness-actuation") is Actuation.KINEMATIC:
        return ControlMode.KINEMATIC
    if isinstance(mode, Mapping):
        return {j: (m if m in _DYNAMIC else ControlMode.POSITION) for j, m in mode.items()}
    return mode if mode in _DYNAMIC else ControlMode.POSITION


def suite_robots(robots: Any, suite: Actuation | None) -> tuple[list[Any], Any]:
    """The marker's ``robots`` (RobotSpecs) with ``--harness-actuation`` applied to each, and
    the control mode the golden name carries (one mode, or MuJoCo joint name -> mode)."""
    import dataclasses

    specs = [dataclasses.replace(spec, control=suite_mode(spec.control, suite)) for spec in robots]
    controls = [spec.control for spec in specs]
    if all(isinstance(c, str) for c in controls) and len(set(controls)) == 1:
        return specs, controls[0]
    combined: dict[str, Any] = {}
    for spec in specs:
        prefix = f"{spec.namespace}/" if spec.namespace else ""
        if isinstance(spec.control, Mapping):
            combined.update({prefix + j: m for j, m in spec.control.items()})
        else:
            combined[prefix + "*"] = spec.control
    return specs, combined


def one_mode(mode: Any) -> Any:
    """A scenario robot's modes (every controllable joint listed) as one mode when they are
    all the same (the golden name ``[kinematic]``, as for ``mode="kinematic"``)."""
    if isinstance(mode, Mapping) and len(set(mode.values())) == 1:
        return next(iter(mode.values()))
    return mode


def resolve_path(value: Any, item: pytest.Item, rootdir: Path) -> Any:
    """A relative model/scenario path against the test's folder, then the rootdir."""
    if not isinstance(value, str | os.PathLike):
        return value
    text = os.fspath(value)
    if text.startswith("package://"):
        # the package search starts at the test's folder (else a load error names the search)
        from harness.errors import HarnessError
        from harness.models.files.resolve import resolve_uri

        try:
            return resolve_uri(text, base_dir=item.path.parent, what="robot file")
        except HarnessError:
            return value
    if not ("/" in text or os.sep in text or Path(text).suffix):
        return value  # a built-in name ("demo", "table")
    path = Path(text)
    if path.is_absolute():
        return path
    for base in (item.path.parent, rootdir):
        if (base / path).exists():
            return (base / path).resolve()
    return value
