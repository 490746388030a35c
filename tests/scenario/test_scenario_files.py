"""Scenario and runner files: examples, the original framework's formats, broken configs, and
agreement between the shipped JSON Schemas and the dataclasses."""

import dataclasses
import json
import shutil
from pathlib import Path

import pytest
import yaml

from harness.events import LOGGING_SCHEMA, SinkSpec
from harness.models import WorldObject
from harness.scenario import Scenario, ScenarioError, load_run_file
from harness.scenario import scenario as sc
from harness.scenario._validation import schema, validator
from tests.scenario.scenario_testlib import DATA, EXAMPLES

BROKEN = DATA / "broken"


def _document(path: Path):
    text = path.read_text()
    return json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)


def _is_runner(doc) -> bool:
    return isinstance(doc, dict) and "simulations" in doc


@pytest.mark.parametrize(
    "path",
    sorted([*EXAMPLES.glob("*.yaml"), *EXAMPLES.glob("*.json")]),
    ids=lambda p: p.name,
)
def test_every_example_loads_and_validates_against_its_schema(path):
    doc = _document(path)
    validator("runner" if _is_runner(doc) else "scenario").validate(doc)
    config = load_run_file(path)
    assert config.simulations
    for plan in config.simulations:
        assert plan.scenario.robots
        assert plan.sim_time_limit > 0


def test_demo_scenario_content():
    demo = Scenario.load(EXAMPLES / "demo.yaml")
    assert demo.name == "demo"
    assert demo.environment.map == "table"
    assert demo.robots[0].robot == "demo"
    assert demo.robots[0].name == "arm"
    assert demo.clock.mode == "lockstep"
    assert demo.criteria.allowed_collisions == (("*", "box"),)
    assert demo.criteria.deterministic
    kinds = [type(lg).__name__ for lg in demo.robots[0].loggers]
    assert kinds == ["CollisionLoggerSpec", "JointLoggerSpec"]
    assert demo.robots[0].loggers[1] == sc.JointLoggerSpec(rate=50.0)
    assert demo.objects[0].name == "marker"
    assert demo.objects[0].mass is None  # fixed
    assert demo.client is not None
    assert demo.client.command[:2] == ("python", "clients/demo_arm.py")


def test_original_scene_config_port_as_number():
    s = Scenario.load(DATA / "config.json")
    assert s.bridge == sc.ScenarioBridgeSection("127.0.0.1", 9090)
    assert s.environment == sc.Environment("empty", "sunny", "noon")
    assert s.robots[0].robot == (DATA / "robots" / "two_link.urdf").resolve()
    assert s.robots[0].subscribers == (sc.Subscriber("JointStateSubscriber", "/joint/states"),)
    assert s.robots[0].modes == (sc.JointModes("kinematic"),)
    assert s.logging.enable
    assert s.logging.destinations == (SinkSpec("seq", (("endpoint", "http://localhost:5341"),)),)


def test_original_scene_config_port_as_string_and_dynamic_mode():
    s = Scenario.load(DATA / "config_port_string.json")
    assert s.bridge.port == 9091
    assert isinstance(s.bridge.port, int)
    assert s.environment == sc.Environment("table", "rainy", "night")
    assert s.robots[0].position == (0.5, 0.0, 0.0)
    # The original's dynamic mode drove position motors; its subscriber default topic is kept.
    assert s.robots[0].modes[0].mode == "position"
    assert s.robots[0].subscribers[0].topic == "/joint/states"


def test_original_runner_config():
    config = load_run_file(DATA / "runner.json")
    (plan,) = config.simulations
    assert plan.name == "MoveIt2 Pick and Place Demo"
    assert plan.iterations == 3
    assert plan.sim_time_limit == 25.0
    assert plan.scenario.source == (DATA / "config.json").resolve()
    assert plan.client is not None
    assert plan.client.command == (
        "ros2",
        "launch",
        "moveit2_tutorials",
        "pick_place_demo.launch.py",
    )
    assert plan.client.readiness_timeout == 10.0
    assert plan.client.cwd == DATA.resolve()
    assert {n.split(": ")[1] for n in config.notices} == {"restartBridge", "ueProject"}


def test_command_takes_precedence_and_launch_without_package(tmp_path):
    shutil.copy(DATA / "config.json", tmp_path / "config.json")
    (tmp_path / "robots").mkdir()
    shutil.copy(DATA / "robots" / "two_link.urdf", tmp_path / "robots" / "two_link.urdf")
    runner = {
        "workers": 3,
        "simulations": [
            {
                "name": "a",
                "ueScenario": "config.json",
                "ros2Pkg": "p",
                "ros2Launch": "l.py",
                "command": "python3 my_client.py --fast 'two words'",
                "env": {"X": "1"},
            },
            {
                "name": "b",
                "scenario": "config.json",
                "ros2Launch": "/abs/demo.launch.py",
                "wallTimeout": 7,
            },
            {"name": "c", "scenario": "config.json"},
            {"name": "d", "scenario": "config.json", "ros2Launch": "d.py", "wall_timeout": 8},
        ],
    }
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(runner))
    config = load_run_file(tmp_path / "run.yaml")
    a, b, c, d = config.simulations
    assert config.workers == 3
    assert a.client.command == ("python3", "my_client.py", "--fast", "two words")
    assert a.client.env == {"X": "1"}
    assert b.client.command == ("ros2", "launch", "/abs/demo.launch.py")
    assert b.client.wall_timeout == 7.0
    assert d.client.wall_timeout == 8.0  # our snake_case spelling of the same option
    assert c.client is None
    assert c.sim_time_limit == c.scenario.duration == 10.0


def test_relative_paths_resolve_against_the_file_not_the_cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    s = Scenario.load(DATA / "config.json")
    assert s.robots[0].robot == (DATA / "robots" / "two_link.urdf").resolve()


def test_scenario_client_section(tmp_path):
    doc = {
        "robots": [{"robot": "demo"}],
        "client": {"command": ["node", "client.js"], "readiness_timeout": 2.5},
    }
    s = Scenario.from_mapping(doc, base_dir=tmp_path)
    assert s.client == sc.ClientSpec(("node", "client.js"), tmp_path, {}, 2.5, 600.0)


# (file, fragments every one of which must appear in the error message, schema-level?)
BROKEN_CASES = [
    ("typo_key.yaml", ["typo_key.yaml: tiemstep: unknown key (did you mean 'timestep'?)"], True),
    (
        "wrong_type.yaml",
        [
            'duration: "ten" is not of type number',
            'robots[0].position[1]: "one" is not of type number',
        ],
        True,
    ),
    ("missing_robot.yaml", ["robots[0].robot: 'models/missing.urdf' not found"], False),
    ("negative_duration.yaml", ["duration: -1.5 must be greater than 0"], True),
    (
        "unknown_asset.json",
        ["robots[0].robot: 'UR5_Robot' is not a built-in robot (built-ins: demo)"],
        False,
    ),
    ("bad_port_number.json", ["ros.bridge.port: 70000 must be at most 65535"], True),
    (
        "many_errors.yaml",
        [
            "6 problems",
            'environment.weather: "foggy" is not one of',
            "robots[0].positon: unknown key (did you mean 'position'?)",
            'robots[1].controllers[0].mode: "telekinetic" is not one of',
            'ros.bridge.port: "ninety" does not match',
            "seed: -3 must be at least 0",
            "environment.map: 'moon' is not a built-in scene (built-ins: empty, table)",
        ],
        True,
    ),
    (
        "runner_typo.json",
        [
            "simulations[0].maxSimtime: unknown key (did you mean 'maxSimTime'?)",
            "simulations[0].iterations: 0 must be at least 1",
        ],
        True,
    ),
    (
        "runner_broken_scenario.json",
        [
            "simulations[0].ueScenario: ",
            "negative_duration.yaml: duration: -1.5 must be greater than 0",
        ],
        False,
    ),
    ("invalid.yaml", ["invalid.yaml:2:1: invalid YAML"], None),
]


@pytest.mark.parametrize(
    ("name", "fragments", "schema_level"), BROKEN_CASES, ids=[c[0] for c in BROKEN_CASES]
)
def test_broken_configs_name_key_path_and_value(name, fragments, schema_level):
    path = BROKEN / name
    with pytest.raises(ScenarioError) as info:
        load_run_file(path)
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message
    assert all(str(path.resolve()) in p for p in info.value.problems)
    if schema_level is None:
        return
    doc = _document(path)
    errors = list(validator("runner" if _is_runner(doc) else "scenario").iter_errors(doc))
    # The editor schema catches exactly the schema-level problems; file references and
    # built-in names are checked by the loader only.
    assert bool(errors) == schema_level


def _props(name: str) -> set[str]:
    s = schema("scenario")
    node = s if name == "" else s["$defs"].get(name) or s["properties"][name]
    return set(node["properties"])


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)}


def test_schema_and_dataclasses_agree():
    top = schema("scenario")["properties"]
    assert _props("") - {"$schema", "ros"} == _fields(sc.Scenario) - {"bridge", "source"}
    bridge = set(top["ros"]["properties"]["bridge"]["properties"])
    assert bridge == _fields(sc.ScenarioBridgeSection)
    assert _props("environment") == _fields(sc.Environment)
    assert _props("robot") - {"controllers"} == _fields(sc.ScenarioRobot) - {"named"}
    assert _props("subscriber") == _fields(sc.Subscriber)
    assert _props("controller") - {"type", "beyond_limits"} == _fields(sc.Controller)
    # an object is a WorldObject: the file's position and orientation are its pose
    assert _props("object") == _fields(WorldObject) - {"pose"} | {"position", "orientation"}
    assert _props("recording") == _fields(sc.ScenarioRecordingSection)
    assert _props("criteria") == _fields(sc.Criteria)
    assert _props("clock") == _fields(sc.Clock)
    assert top["logging"]["$ref"] == "logging.schema.json"
    assert LOGGING_SCHEMA["$id"].endswith("/logging.schema.json")
    assert _props("client") == _fields(sc.ClientSpec)  # cwd: the file's folder by default
    assert _props("logger") - {"type", "self_collision"} == _fields(
        sc.CollisionLoggerSpec
    ) | _fields(sc.JointLoggerSpec)
    assert set(sc._LOGGER_KEYS["CollisionLogger"]) - {"self_collision"} == _fields(
        sc.CollisionLoggerSpec
    )
    assert set(sc._LOGGER_KEYS["JointLogger"]) == _fields(sc.JointLoggerSpec)
    enum = schema("scenario")["$defs"]["logger"]["properties"]["type"]["enum"]
    assert set(enum) == set(sc._LOGGER_KEYS)


def test_logger_option_of_the_other_logger_is_refused():
    doc = {"robots": [{"robot": "demo", "loggers": [{"type": "JointLogger", "min_force": 1}]}]}
    with pytest.raises(
        ScenarioError,
        match=r"robots\[0\]\.loggers\[0\]\.min_force: 1 is not an "
        r"option of JointLogger",
    ):
        Scenario.from_mapping(doc)


def test_duplicate_names_and_object_size_are_checked():
    doc = {
        "robots": [{"robot": "demo", "name": "a"}, {"robot": "demo", "name": "a"}],
        "objects": [{"name": "b", "shape": "sphere", "size": [0.1, 0.2]}],
    }
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(doc)
    text = str(info.value)
    assert "robots[1].name: 'a' is already the name of robots[0]" in text
    assert "objects[0].size: [0.1, 0.2] needs 1 number(s) for a sphere" in text


def test_scenarios_pickle_and_compare_equal():
    import pickle

    s = Scenario.load(EXAMPLES / "demo.yaml")
    assert pickle.loads(pickle.dumps(s)) == s


def test_scenario_ros_routes(tmp_path):
    doc = {
        "robots": [{"robot": "demo"}],
        "ros": {"bridge": {"connect": "ws://127.0.0.1:9090/?token=t", "ros2": True}},
    }
    s = Scenario.from_mapping(doc, base_dir=tmp_path)
    assert s.bridge.connect == "ws://127.0.0.1:9090/?token=t"
    assert s.bridge.ros2 is True
    assert Scenario.from_mapping({"robots": [{"robot": "demo"}]}).bridge.connect is None
    with pytest.raises(ScenarioError, match="connect"):
        Scenario.from_mapping({"robots": [{"robot": "demo"}], "ros": {"bridge": {"connect": "x"}}})
