"""``environment.map`` may be an SDF world: as it is, or with the scenario's objects added."""

from __future__ import annotations

from pathlib import Path

import mujoco

from harness.scenario import Scenario
from harness.scenario.world import build_world, scene_for

DATA = Path(__file__).resolve().parents[1] / "data"
WORLD = DATA / "worlds" / "room.world"
TWO_LINK = DATA / "scenario" / "robots" / "two_link.urdf"


def _scenario(objects: list[dict[str, object]]) -> Scenario:
    return Scenario.from_mapping(
        {
            "robots": [{"robot": str(TWO_LINK)}],
            "environment": {"map": str(WORLD)},
            "objects": objects,
        }
    )


def test_an_sdf_world_map_is_the_scene_as_it_is(tmp_path: Path) -> None:
    scenario = _scenario([])
    assert scene_for(scenario, tmp_path) == WORLD
    world = build_world(scenario, tmp_path)
    names = {world.model.body(b).name for b in range(world.model.nbody)}
    assert {"wall::link", "crate::body", "arm"} <= names
    assert any(name.startswith("scene/include/") for name in world.sources)


def test_scenario_objects_join_an_sdf_world(tmp_path: Path) -> None:
    scenario = _scenario(
        [{"name": "ball", "shape": "sphere", "size": [0.05], "position": [0.5, 0, 0.3], "mass": 1}]
    )
    model = mujoco.MjModel.from_xml_path(str(scene_for(scenario, tmp_path)))
    assert model.body("ball").id > 0
    assert model.body("crate::body").id > 0


def test_world_is_the_scene_option_in_session_and_marker(pytester) -> None:
    """``world=`` (as Gazebo users name the map) is ``scene=``: the same bodies load; giving
    both is refused with one line."""
    import pytest

    from harness.session import Session, SessionConfigError

    with Session(TWO_LINK, world=WORLD) as session:
        names = {session.sim.model.body(b).name for b in range(session.sim.model.nbody)}
    assert {"wall::link", "crate::body", "arm"} <= names
    with pytest.raises(SessionConfigError, match="world and scene name the same option"):
        Session(TWO_LINK, world=WORLD, scene="empty")
    pytester.makepyfile(
        test_world=f"""
        import pytest

        @pytest.mark.harness(robot={str(TWO_LINK)!r}, world={str(WORLD)!r})
        def test_it(harness_session):
            model = harness_session.sim.model
            assert "crate::body" in {{model.body(b).name for b in range(model.nbody)}}
        """
    )
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider")  # the plugin: entry point
    result.assert_outcomes(passed=1)
