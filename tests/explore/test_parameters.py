"""explore.parameters: paths by the scenario's own keys, nominal + delta, one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from harness.explore import (
    ExploreConfigError,
    apply_values,
    load_plan,
    parameter_delta,
    parse_parameters,
    scenario_values,
)
from tests.explore.conftest import DATA

DOC = {
    "robots": [{"robot": "demo", "initial_joint_positions": {"joint1": 0.1}}],
    "objects": [{"name": "obstacle", "shape": "sphere", "size": [0.03], "position": [0, 0, 1]}],
    "client": {"command": "x", "env": {"TARGET_X": "0.2"}},
    "seed": 7,
}


def _params(parameters: dict) -> tuple:
    return parse_parameters({**DOC, "explore": {"parameters": parameters}}, "s.yaml")


def test_paths_resolve_by_name_index_and_alias() -> None:
    p = _params(
        {
            "objects.obstacle.position": {"low": [-1, -1, 1], "high": [1, 1, 1]},
            "robots.0.initial_positions.joint1": {"low": -0.3, "high": 0.3},
            "robots.0.initial_positions.joint2": {"low": -0.3, "high": 0.3},
            "client.env.TARGET_X": {"choices": ["0.1", "0.2", "0.3"]},
            "seed": {"integers": [0, 1000]},
        }
    )
    by = {q.path: q for q in p}
    assert by["objects.obstacle.position"].tokens == ("objects", 0, "position")
    assert by["objects.obstacle.position"].nominal == [0.0, 0.0, 1.0]
    assert by["robots.0.initial_positions.joint1"].tokens == (
        "robots",
        0,
        "initial_joint_positions",
        "joint1",
    )
    assert by["robots.0.initial_positions.joint1"].nominal == 0.1
    assert by["robots.0.initial_positions.joint2"].nominal == -0.3  # absent: the range's low
    assert by["client.env.TARGET_X"].choices == ("0.2", "0.1", "0.3")  # the nominal first
    assert by["seed"].nominal == 7


def test_delta_zero_is_the_scenario_as_written() -> None:
    p = _params({"objects.obstacle.position": {"low": [-1, -1, 1], "high": [1, 1, 1]}})[0]
    assert p.value_of([0.0, 0.0, 0.0]) == [0.0, 0.0, 1.0]
    assert p.value_of([5.0, -0.5, 0.0]) == [1.0, -0.5, 1.0]  # clipped into the box
    doc = apply_values({**DOC, "explore": {}}, [p], {p.path: [0.5, 0.5, 1.0]})
    assert "explore" not in doc
    assert doc["objects"][0]["position"] == [0.5, 0.5, 1.0]
    assert DOC["objects"][0]["position"] == [0, 0, 1]  # the original is untouched


@given(st.data())
@settings(max_examples=50, deadline=None)
def test_drawn_values_stay_in_range_and_shrink_to_nominal(data) -> None:
    p = _params({"robots.0.initial_positions.joint1": {"low": -0.3, "high": 0.5}})[0]
    delta = data.draw(parameter_delta(p))
    assert -0.3 <= p.value_of(delta) <= 0.5


def test_minimal_delta_is_zero() -> None:
    from hypothesis import find

    p = _params({"robots.0.initial_positions.joint1": {"low": -0.3, "high": 0.5}})[0]
    # hypothesis shrinks a delta toward 0: the smallest example is the nominal value
    assert p.value_of(find(parameter_delta(p), lambda d: True)) == 0.1


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        (
            {"objects.nope.position": {"low": 0, "high": 1}},
            "objects has no entry named 'nope' (its names: obstacle)",
        ),
        ({"objects.obstacle.position": {"low": 0, "high": 1}}, "is not a number"),
        (
            {"objects.obstacle.position": {"low": [0, 0], "high": [1, 1]}},
            "is not a list of 2 numbers",
        ),
        ({"seed": {"low": 5, "high": 1}}, "low 5 is above high 1"),
        ({"seed": {"low": 5}}, "a range needs both low and high"),
        ({"seed": {"low": 1, "high": 2, "choices": [1]}}, "give exactly one of"),
        (
            {"robots.3.initial_positions.j": {"low": 0, "high": 1}},
            "robots has 1 entries (no index 3)",
        ),
        ({"environment.map": {"choices": ["empty"]}}, "the scenario has no 'environment'"),
    ],
)
def test_bad_parameters_are_one_line(parameters: dict, message: str) -> None:
    with pytest.raises(ExploreConfigError) as info:
        _params(parameters)
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith("s.yaml: explore.parameters.")
    assert message in text


def test_a_bound_that_breaks_the_scenario_is_refused(tmp_path: Path) -> None:
    doc = yaml.safe_load((DATA / "sweep.yaml").read_text())
    doc["explore"]["parameters"]["objects.obstacle.size"] = {"low": [-0.01], "high": [0.05]}
    path = tmp_path / "neg.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(
        ExploreConfigError,
        match=r"neg\.yaml: explore\.parameters\.objects\.obstacle\.size: \[-0\.01\] makes the "
        r"scenario invalid",
    ):
        load_plan(path)


def test_concrete_text_runs_from_any_folder(tmp_path: Path) -> None:
    plan = load_plan(DATA / "reach.yaml")
    text = plan.text(plan.nominal())
    doc = yaml.safe_load(text)
    assert "explore" not in doc
    assert doc["client"]["cwd"] == str(DATA)  # relative client paths keep working elsewhere
    assert plan.text(plan.nominal()) == text  # a pure function of the values


@settings(max_examples=5, deadline=None)
@given(values=scenario_values(DATA / "sweep.yaml"))
def test_strategies_work_with_given(values: dict) -> None:
    x, y, z = values["objects.obstacle.position"]
    assert -0.3 <= x <= 0.7
    assert -0.6 <= y <= 0.6
    assert z == 0.5
