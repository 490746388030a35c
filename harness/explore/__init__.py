"""Failure search over a scenario's declared parameters (``harness explore``).

A scenario's ``explore`` section names what may vary, by the scenario's own keys
(:mod:`harness.explore.parameters`); hypothesis searches those values (one engine per worker,
``target()`` on a margin, shrinking toward the scenario as written:
:mod:`harness.explore.engine`), each example run as ``harness run`` runs it
(:mod:`harness.explore.episode`); the minimal failure comes back as a scenario, its recording
and a regression test (:mod:`harness.explore.outputs`), with a report
(:mod:`harness.explore.report`). In pytest, :func:`scenario_values` is a strategy over the
same parameters for ``@given``.
"""

from harness.explore.engine import EngineOptions, EngineOutcome, FailureTrack, run_engine
from harness.explore.episode import EpisodeRunner, Example, margins_of, signature_of
from harness.explore.errors import ExploreConfigError, ExploreError
from harness.explore.kernel import KernelRunner
from harness.explore.outputs import (
    MinimalCase,
    regression_test,
    run_scenario,
    write_minimal,
    write_summary,
)
from harness.explore.parameters import Parameter, apply_values, parse_parameters
from harness.explore.plan import TARGETS, ExplorePlan, load_plan
from harness.explore.search import SearchOptions, SearchResult, search
from harness.explore.strategies import (
    concrete_scenario,
    delta_strategy,
    parameter_delta,
    scenario_values,
    values_strategy,
)

__all__ = [
    "TARGETS",
    "EngineOptions",
    "EngineOutcome",
    "EpisodeRunner",
    "Example",
    "ExploreConfigError",
    "ExploreError",
    "ExplorePlan",
    "FailureTrack",
    "KernelRunner",
    "MinimalCase",
    "Parameter",
    "SearchOptions",
    "SearchResult",
    "apply_values",
    "concrete_scenario",
    "delta_strategy",
    "load_plan",
    "margins_of",
    "parameter_delta",
    "parse_parameters",
    "regression_test",
    "run_engine",
    "run_scenario",
    "scenario_values",
    "search",
    "signature_of",
    "values_strategy",
    "write_minimal",
    "write_summary",
]
