"""A scenario file read for exploration: its document, parameters and concrete examples.

:class:`ExplorePlan` holds the scenario's document as written (relative paths made absolute,
so a concrete scenario runs from any folder: ``--out`` holds ``minimal.yaml``), the parsed
:class:`~harness.explore.parameters.Parameter`\\ s, and turns a set of values into the
concrete scenario's text: the one text an example runs, records (the scenario attachment) and,
for the minimal failure, writes as ``minimal.yaml``. The text is a pure function of the
values, so ``harness run minimal.yaml`` records the same bytes as the example did.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import yaml  # type: ignore[import-untyped,unused-ignore]

from harness.explore.errors import ExploreConfigError
from harness.explore.parameters import Parameter, apply_values, parse_parameters
from harness.explore.valuecheck import ValueChecker
from harness.scenario import Scenario, ScenarioError, schema_validator

__all__ = ["TARGETS", "ExplorePlan", "load_plan"]

TARGETS = ("min_clearance", "peak_force", "limit_margin", "tracking_error")
"""The margins ``explore.target`` may name."""

_ROBOT_SUFFIXES = (".urdf", ".xacro", ".sdf", ".xml", ".mjcf")
_WORLD_SUFFIXES = (".xml", ".mjcf", ".sdf", ".world")


def _pathlike(value: str, suffixes: tuple[str, ...]) -> bool:
    return "://" not in value and (
        "/" in value or "\\" in value or Path(value).suffix.lower() in suffixes
    )


def _absolute(doc: dict[str, Any], base: Path) -> dict[str, Any]:
    """``doc`` with the file references the scenario loader resolves against the file's folder
    made absolute (``package://`` and built-in names kept), and the client's folder fixed."""
    env = doc.get("environment")
    world = env.get("map") if isinstance(env, dict) else None
    if isinstance(env, dict) and isinstance(world, str) and _pathlike(world, _WORLD_SUFFIXES):
        env["map"] = str((base / world).resolve())
    for robot in doc.get("robots") or []:
        if isinstance(robot, dict):
            if isinstance(robot.get("robot"), str) and _pathlike(robot["robot"], _ROBOT_SUFFIXES):
                robot["robot"] = str((base / robot["robot"]).resolve())
            if isinstance(robot.get("srdf"), str) and "://" not in robot["srdf"]:
                robot["srdf"] = str((base / robot["srdf"]).resolve())
    controllers = doc.get("controllers")
    if isinstance(controllers, str):
        doc["controllers"] = str((base / controllers).resolve())
    elif isinstance(controllers, list):
        doc["controllers"] = [
            str((base / c).resolve()) if isinstance(c, str) else c for c in controllers
        ]
    client = doc.get("client")
    if isinstance(client, dict):
        client["cwd"] = str((base / client.get("cwd", ".")).resolve())
    return doc


@dataclass(frozen=True)
class ExplorePlan:
    """A scenario file's exploration (see the module docstring). ``document``: the scenario
    as written with absolute paths, ``explore`` section included; ``target``: the margin
    hypothesis' ``target()`` drives (None: none); ``plot``: the two components the report
    plots."""

    source: Path
    document: Mapping[str, Any]
    parameters: tuple[Parameter, ...]
    target: str | None
    plot: tuple[str, str] | None

    @property
    def digest(self) -> bytes:
        """What tells this exploration from another (the hypothesis database key)."""
        text = json.dumps(self.document, sort_keys=True, default=str)
        return hashlib.sha256(f"{self.source}\n{text}".encode()).digest()

    def nominal(self) -> dict[str, Any]:
        """Every parameter at its nominal value (the scenario as written)."""
        return {p.path: p.nominal for p in self.parameters}

    def text(self, values: Mapping[str, Any]) -> str:
        """The concrete scenario for ``values`` (no ``explore`` section), as YAML text."""
        doc = apply_values(self.document, self.parameters, values)
        header = (
            f"# A concrete case of {self.source.name} found by `harness explore`; run it with\n"
            "# `harness run` (paths are absolute: it runs from any folder).\n"
        )
        body: str = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=100)
        return header + body

    def concrete(self, values: Mapping[str, Any]) -> tuple[dict[str, Any], Scenario]:
        """The concrete document for ``values`` (:func:`apply_values`) and its
        :class:`~harness.scenario.Scenario`: what :meth:`Scenario.from_mapping` makes of the
        document, the same problems raised, but with the scenario schema checked at the
        parameters' places only where that gives the same verdict
        (:class:`~harness.explore.valuecheck.ValueChecker`: an example's cost)."""
        document = apply_values(self.document, self.parameters, values)
        scenario = Scenario.from_mapping(
            document,
            base_dir=self.source.parent,
            source=self.source,
            schema=self.value_checker is None or not self.value_checker.valid(values),
        )
        return document, scenario

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("value_checker", None)  # a jsonschema validator: found again where used
        return state

    @cached_property
    def value_checker(self) -> ValueChecker | None:
        """The schema at the parameters' places in the nominal document, found once per plan
        (None: the nominal document is not schema-valid; every example is checked in full)."""
        template = apply_values(self.document, self.parameters, self.nominal())
        validator = schema_validator("scenario")
        if not validator.is_valid(template):
            return None
        return ValueChecker(validator, template, self.parameters)

    def check(self, values: Mapping[str, Any], file: Path) -> Scenario:
        """The concrete scenario for ``values``, validated (written to ``file``)."""
        file.write_text(self.text(values), encoding="utf-8")
        return Scenario.load(file)


def load_plan(path: str | Path) -> ExplorePlan:
    """Read a scenario file with an ``explore`` section: the whole file validated as
    ``harness run`` would (:class:`~harness.scenario.ScenarioError` listing every problem),
    then the section's parameters (:class:`ExploreConfigError`, one line)."""
    source = Path(path).resolve()
    if not source.is_file():
        raise ExploreConfigError(f"{path}: no such scenario file")
    scenario = Scenario.load(source)  # every problem of the file, as harness run reports
    if scenario.explore is None:
        raise ExploreConfigError(
            f"{source}: explore: the scenario has no explore section "
            "(explore: {parameters: {KEY: {low: .., high: ..}}})"
        )
    doc = yaml.safe_load(source.read_text(encoding="utf-8"))
    doc = _absolute(doc, source.parent)
    where = str(source)
    parameters = parse_parameters(doc, where)
    section = doc["explore"]
    plot = section.get("plot")
    labels = [label for p in parameters for label in p.labels()]
    if plot is not None:
        for name in plot:
            if name not in labels:
                raise ExploreConfigError(
                    f"{where}: explore.plot: {name!r} is not a parameter component "
                    f"(components: {', '.join(labels)})"
                )
    elif len(labels) >= 2:
        plot = labels[:2]
    plan = ExplorePlan(
        source,
        doc,
        parameters,
        section.get("target"),
        (str(plot[0]), str(plot[1])) if plot else None,
    )
    _check_nominal(plan)
    return plan


def _check_nominal(plan: ExplorePlan) -> None:
    """The scenario with every parameter at a bound must still be a valid scenario (a bad
    range, say a negative size, is reported now, naming the parameter, not mid-search)."""
    doc = plan.document
    for p in plan.parameters:
        for values in (p.low, p.high) if p.kind != "choices" else ():
            value: Any = list(values) if p.vector else values[0]
            if p.kind == "integers":
                value = int(value)
            trial = apply_values(doc, plan.parameters, {**plan.nominal(), p.path: value})
            try:
                Scenario.from_mapping(trial, base_dir=plan.source.parent, source=plan.source)
            except ScenarioError as exc:
                raise ExploreConfigError(
                    f"{plan.source}: explore.parameters.{p.path}: {value!r} makes the scenario "
                    f"invalid: {exc.problems[0]}"
                ) from None
