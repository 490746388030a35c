"""hypothesis strategies over a scenario's explore parameters.

:func:`delta_strategy` draws what hypothesis shrinks (each parameter's delta from its
nominal value: shrinking moves toward the scenario as written); :func:`values_strategy` maps
that to the parameters' concrete values; :func:`scenario_values` is the same for use with
``@given`` in a test::

    from hypothesis import given, settings
    from harness.explore import scenario_values, concrete_scenario

    @settings(max_examples=20, deadline=None)
    @given(values=scenario_values("cell.yaml"))
    def test_cell(values, tmp_path_factory, harness_session_factory):
        path = concrete_scenario("cell.yaml", values, tmp_path_factory.mktemp("case"))
        ...
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from harness.explore.parameters import Parameter
from harness.explore.plan import ExplorePlan, load_plan

__all__ = [
    "concrete_scenario",
    "delta_strategy",
    "parameter_delta",
    "scenario_values",
    "values_strategy",
]


def parameter_delta(p: Parameter) -> st.SearchStrategy[Any]:
    """The delta of one parameter from its nominal value (a choice: the value itself, the
    nominal first, so it shrinks to the nominal)."""
    if p.kind == "choices":
        return st.sampled_from(p.choices)
    if p.kind == "integers":
        n = int(p.nominal)
        return st.integers(int(p.low[0]) - n, int(p.high[0]) - n)
    nominals = [float(v) for v in p.nominal] if p.vector else [float(p.nominal)]
    parts = [
        st.just(0.0)
        if lo == hi
        else st.floats(
            min_value=min(lo - n, 0.0),
            max_value=max(hi - n, 0.0),
            allow_nan=False,
            allow_infinity=False,
            allow_subnormal=False,
        )
        for n, lo, hi in zip(nominals, p.low, p.high, strict=True)
    ]
    if p.vector:
        return st.tuples(*parts).map(list)
    return parts[0]


def delta_strategy(plan: ExplorePlan) -> st.SearchStrategy[dict[str, Any]]:
    """Every parameter's delta, by path."""
    return st.fixed_dictionaries({p.path: parameter_delta(p) for p in plan.parameters})


def to_values(plan: ExplorePlan, deltas: Mapping[str, Any]) -> dict[str, Any]:
    """The parameters' values for drawn deltas (clipped into each range)."""
    return {p.path: p.value_of(deltas[p.path]) for p in plan.parameters}


def values_strategy(plan: ExplorePlan) -> st.SearchStrategy[dict[str, Any]]:
    """Every parameter's concrete value, by path (drawn as nominal + delta)."""
    return delta_strategy(plan).map(lambda deltas: to_values(plan, deltas))


def scenario_values(path: str | Path) -> st.SearchStrategy[dict[str, Any]]:
    """The strategy of a scenario file's ``explore.parameters`` (for ``@given``)."""
    return values_strategy(load_plan(path))


def concrete_scenario(path: str | Path, values: Mapping[str, Any], folder: Path) -> Path:
    """Write the concrete scenario of ``values`` to ``folder/scenario.yaml`` (validated) and
    return its path: what ``harness run`` or ``@pytest.mark.harness(scenario=...)`` runs."""
    plan = load_plan(path)
    folder.mkdir(parents=True, exist_ok=True)
    file = folder / "scenario.yaml"
    plan.check(values, file)
    return file
