"""The session's options objects (issue 16, item 4): one group per concern, the keyword
arguments a thin layer derived from their fields, the metadata codec and the marker keys
derived from the fields too."""

from __future__ import annotations

import dataclasses

import pytest

from harness.controllers import load_controllers
from harness.pytest_plugin import marker_keys
from harness.recording import Recording
from harness.session import Session, SessionConfigError
from harness.session.core.options import (
    SESSION_KEYWORDS,
    CoreOptions,
    LoadOptions,
    RecordOptions,
    SessionKeywords,
    TransportOptions,
)

# A value other than the default for every CoreOptions field: a field added later without a
# codec, or whose codec loses it, fails the round trip below.
NOT_DEFAULT = {
    "clock": "realtime",
    "rate": 2.5,
    "namespace": "arm",
    "kinematic_limits": "allow",
    "state_every": 3,
    "joint_states_hz": 50.0,
    "tf_hz": 25.0,
    "clock_hz": 0.0,
    "joint_command_topic": {"arm": "/arm/cmd"},
    "start": "paused",
    "record_bridge_frames": False,
    "max_step_request": 7,
    "controllers": "none",
    "sensors": ({"name": "imu", "type": "imu", "parent": "link1"},),
    "seed": 11,
}


def test_every_core_option_survives_the_metadata() -> None:
    assert set(NOT_DEFAULT) == {f.name for f in dataclasses.fields(CoreOptions)}
    options = CoreOptions(**NOT_DEFAULT)  # type: ignore[arg-type]
    for f in dataclasses.fields(CoreOptions):
        assert getattr(options, f.name) != f.default, f.name
    metadata = options.to_metadata()
    # state_every and seed are written by the recorder and describe_run, as in a recording
    assert "state_every" not in metadata
    assert "seed" not in metadata
    metadata |= {"state_every": "3", "seed": "11"}
    assert CoreOptions.from_metadata(metadata) == options
    assert CoreOptions.from_metadata({}) == CoreOptions(controllers="none")  # an old recording


def test_a_bad_metadata_value_names_its_key() -> None:
    with pytest.raises(SessionConfigError, match="metadata 'tf_hz' is 'fast', not a number"):
        CoreOptions.from_metadata({"tf_hz": "fast"})
    with pytest.raises(SessionConfigError, match="metadata 'max_step_request' is '-1'"):
        CoreOptions.from_metadata({"max_step_request": "-1"})


def test_the_keywords_are_the_fields() -> None:
    assert set(SessionKeywords.__optional_keys__) == {*SESSION_KEYWORDS, "world"}
    groups = {"options": CoreOptions, "transport": TransportOptions}
    groups |= {"record": RecordOptions, "load": LoadOptions}
    for group, cls in groups.items():
        assert {k for k, g in SESSION_KEYWORDS.items() if g == group} == {
            f.name for f in dataclasses.fields(cls)
        }
    core = {f.name for f in dataclasses.fields(CoreOptions)}
    assert core <= marker_keys()
    assert {"host", "port", "token", "record_to"}.isdisjoint(marker_keys())


def test_keywords_and_objects_make_the_same_session(tmp_path) -> None:
    controllers = load_controllers(
        "controller_manager:\n  ros__parameters:\n    joint_state_broadcaster:\n"
        "      type: joint_state_broadcaster/JointStateBroadcaster\n"
    )
    keywords = {
        "clock": "fast",
        "rate": 3.0,
        "start": "paused",
        "namespace": "arm",
        "tf_hz": 10.0,
        "seed": 5,
        "controllers": controllers,
    }
    with Session(**keywords, record_to=tmp_path / "a.mcap", mode="kinematic") as a:  # type: ignore[arg-type]
        pass
    with Session(
        options=CoreOptions(**keywords),  # type: ignore[arg-type]
        record=tmp_path / "b.mcap",
        load=LoadOptions(mode="kinematic"),
    ) as b:
        pass
    assert a.options == b.options
    assert (a.clock, a.rate, a.namespace) == ("fast", 3.0, "arm")
    with Recording(tmp_path / "a.mcap") as ra, Recording(tmp_path / "b.mcap") as rb:
        assert ra.metadata == rb.metadata
        assert ra.metadata["rate"] == "3.0"
        assert ra.metadata["start"] == "paused"


def test_a_group_given_twice_is_refused_before_loading() -> None:
    with pytest.raises(SessionConfigError, match=r"give clock inside options= or as keywords"):
        Session(robot="no-such-robot.urdf", options=CoreOptions(), clock="fast")
    with pytest.raises(SessionConfigError, match="world and scene name the same option"):
        Session(robot="no-such-robot.urdf", scene="table", world="empty")
    with pytest.raises(TypeError, match="unexpected keyword argument 'clok'"):
        Session(clok="fast")  # type: ignore[call-arg]
    with pytest.raises(SessionConfigError, match="rate must be a finite number > 0"):
        Session(robot="no-such-robot.urdf", rate=0.0)
