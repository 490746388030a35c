"""What the search does between two examples costs little, and changes nothing it draws.

- an example's scenario: the schema checked at the parameters' places only (the rest of the
  document is every example's), the same Scenario and the same errors as a full check;
- local workers: worker 0 runs in the calling process (no start-up to wait for), the search
  drawing the same examples for the same seed;
- Dask: the stop flag asks the scheduler at most every poll interval.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings

from harness.explore import SearchOptions, apply_values, load_plan, search, values_strategy
from harness.scenario import Scenario, ScenarioError
from tests.explore.conftest import DATA

CLEAR = load_plan(DATA / "clear.yaml")


def _full(plan: Any, values: dict[str, Any]) -> tuple[dict[str, Any], Scenario]:
    document = apply_values(plan.document, plan.parameters, values)
    return document, Scenario.from_mapping(
        document, base_dir=plan.source.parent, source=plan.source
    )


@settings(max_examples=40, deadline=None)
@given(values=values_strategy(CLEAR))
def test_concrete_scenario_is_the_fully_checked_one(values: dict[str, Any]) -> None:
    assert CLEAR.concrete(values) == _full(CLEAR, values)


def test_schema_is_checked_at_the_parameters_places_only() -> None:
    checker = CLEAR.value_checker
    assert checker is not None
    assert checker.active
    assert checker.places is not None
    size = checker.places["objects.obstacle.size"]
    assert [s.get("type") for s in size] == ["array"]  # the object's size schema, no more
    assert size[0]["items"]["exclusiveMinimum"] == 0


def _variant(tmp_path: Path, parameters: dict[str, Any], **keys: Any) -> Path:
    doc = yaml.safe_load((DATA / "clear.yaml").read_text())
    doc.update(keys)
    doc["explore"] = {"parameters": parameters}
    path = tmp_path / "variant.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_a_value_the_schema_refuses_raises_the_full_checks_problems(tmp_path: Path) -> None:
    choices = [[0.03], [-0.01], [0.01, 0.02], [0.01]]
    plan = load_plan(_variant(tmp_path, {"objects.obstacle.size": {"choices": choices}}))
    assert plan.value_checker is not None
    assert plan.value_checker.active
    for bad in ([-0.01], [0.01, 0.02]):  # the schema's problem; the builder's (a sphere)
        with pytest.raises(ScenarioError) as full:
            _full(plan, {"objects.obstacle.size": bad})
        with pytest.raises(ScenarioError) as fast:
            plan.concrete({"objects.obstacle.size": bad})
        assert fast.value.problems == full.value.problems
        assert "objects[0].size" in fast.value.problems[0]
    assert plan.concrete({"objects.obstacle.size": [0.01]}) == _full(
        plan, {"objects.obstacle.size": [0.01]}
    )


def test_a_place_behind_another_schema_file_is_checked_in_full(tmp_path: Path) -> None:
    """``logging`` is a reference to logging.schema.json: the walk does not follow it, every
    example's document is checked whole."""
    plan = load_plan(
        _variant(
            tmp_path,
            {"logging.frequency": {"low": 10.0, "high": 200.0}},
            logging={"frequency": 100.0},
        )
    )
    assert plan.value_checker is not None
    assert not plan.value_checker.active
    assert plan.concrete({"logging.frequency": 50.0}) == _full(plan, {"logging.frequency": 50.0})


def test_worker_zero_runs_here_and_the_search_draws_the_same_twice(tmp_path: Path) -> None:
    """hypothesis also draws constants found in the local modules its process has imported:
    a first search does this process's lazy imports, the two compared run after it."""
    search(CLEAR, SearchOptions(work=tmp_path / "warm", examples=2, seed=3))
    runs = []
    for name in ("a", "b"):
        options = SearchOptions(work=tmp_path / name, examples=6, workers=2, seed=3)
        result = search(CLEAR, options)
        assert [o.worker for o in result.outcomes] == [0, 1]
        assert result.outcomes[0].process == os.getpid()  # no start-up to wait for
        assert result.outcomes[1].process != os.getpid()
        runs.append(
            [[(e.index, e.values, e.phase, e.digest) for e in o.examples] for o in result.outcomes]
        )
    assert runs[0] == runs[1]
    assert [len(drawn) for drawn in runs[0]] == [3, 3]


@pytest.fixture
def scheduler() -> Any:
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=0,
            processes=False,
            protocol="tcp://",
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
        ) as cluster,
        distributed.Client(cluster.scheduler_address),
    ):
        yield cluster


@pytest.mark.timeout(120)
def test_dask_flag_asks_the_scheduler_at_most_every_poll(scheduler: Any) -> None:
    from harness.explore.dask_workers import DaskFlag

    event = f"stop-{uuid.uuid4().hex}"
    engine = DaskFlag(event, poll=3600.0)
    other = DaskFlag(event, poll=0.0)
    assert not engine.is_set()  # asked the scheduler: not set
    other.set()
    assert not engine.is_set()  # within its poll interval: not asked again
    assert DaskFlag(event, poll=0.0).is_set()  # a flag that asks sees it
    assert DaskFlag(event, poll=3600.0).is_set()  # the first ask always goes out
    engine.set()
    assert engine.is_set()  # its own stop is seen at once
