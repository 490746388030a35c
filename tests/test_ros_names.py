"""One ROS-name validator (``harness.names``, issue 16) used by the session options, the bridge,
world namespaces and package references: the same name gets the same answer everywhere."""

from __future__ import annotations

import json

import pytest

from harness.models.errors import ResolveError
from harness.models.files.resolve import resolve_uri
from harness.models.world.records import InvalidNamespaceError, check_namespace
from harness.names import InvalidNameError, check_name, name_problem, package_problem
from harness.rosbridge import Bridge, TypeRegistry
from harness.session import SessionConfigError
from harness.session.core import CoreOptions

VALID = {
    "topic": ["/joint_states", "joint_states", "/a/b_2/c", "~", "~/private", "/_action/x", "a__b"],
    "namespace": ["arm", "/arm", "arm/", "/left/arm/", "_hidden"],
    "segment": ["arm", "arm_1", "_arm", "A"],
}
INVALID = {
    "topic": ["", "/", "/a/", "a//b", "/1a", "a b", "/bré/joint_states", "~foo", "{node}/x"],
    "namespace": ["/", "a b", "bré", "1arm", "a//b", "~/x"],
    "segment": ["", "a/b", "1arm", "arm-1", "bré"],
}


@pytest.mark.parametrize(("kind", "name"), [(k, n) for k, names in VALID.items() for n in names])
def test_valid_names(kind, name):
    assert name_problem(name, kind) is None
    assert check_name(name, "x", kind) == name


@pytest.mark.parametrize(("kind", "name"), [(k, n) for k, names in INVALID.items() for n in names])
def test_invalid_names_say_why_in_one_line(kind, name):
    problem = name_problem(name, kind)
    assert problem is not None
    with pytest.raises(InvalidNameError) as info:
        check_name(name, "the name", kind)
    message = str(info.value)
    assert message == f"the name {name!r} is not a valid ROS name: it {problem}"
    assert "\n" not in message


def test_the_reasons_name_the_offending_part():
    assert name_problem("/bré/joint_states") == (
        "has 'é': ROS names are ASCII letters, digits, '_' and '/'"
    )
    assert name_problem("/a/") == "ends with '/'"
    assert name_problem("/a/2b") == "has a token starting with a digit ('2b')"
    assert "private namespace" in str(name_problem("~foo"))
    assert name_problem(3) == "is not a string (int)"


def test_core_options_refuse_a_non_ascii_namespace_at_construction():
    with pytest.raises(SessionConfigError) as info:
        CoreOptions(namespace="bré")
    assert str(info.value) == (
        "namespace 'bré' is not a valid ROS name: it has 'é': ROS names are ASCII letters, "
        "digits, '_' and '/'"
    )
    assert CoreOptions(namespace="/left/arm/").namespace == "left/arm"
    with pytest.raises(SessionConfigError, match=r"joint_command_topic\['arm'\] '/cmd/'"):
        CoreOptions(joint_command_topic={"arm": "/cmd/"})


def test_the_bridge_refuses_what_the_options_refuse():
    bridge = Bridge(TypeRegistry())
    conn = bridge.connect()
    for topic in ("/bré/joint_states", "/a/", "~foo"):
        frame = {"op": "advertise", "topic": topic, "type": "std_msgs/String"}
        (out,) = bridge.receive(conn, json.dumps(frame), 0)
        status = json.loads(out.data)
        assert status["level"] == "error"
        expected = f"advertise: Invalid topic name {topic!r}: it {name_problem(topic)}"
        assert status["msg"] == expected
        with pytest.raises(SessionConfigError):
            CoreOptions(joint_command_topic=topic)
    # what the options accept, the bridge accepts
    frame = {"op": "advertise", "topic": "/left/arm/joint_command", "type": "std_msgs/String"}
    assert bridge.receive(conn, json.dumps(frame), 0) == []


def test_world_namespaces_are_one_segment_by_the_same_rules():
    assert check_namespace("_arm", "robots[1]") == "_arm"
    with pytest.raises(InvalidNamespaceError) as info:
        check_namespace("bré", "robots[1]")
    assert str(info.value) == (
        f"robots[1]: namespace 'bré' is not a ROS name segment: it {name_problem('bré')}"
    )


def test_package_names_are_folder_names(tmp_path):
    assert package_problem("example-robot-data") is None
    assert package_problem("ur_description") is None
    assert package_problem("../up") is not None
    with pytest.raises(ResolveError, match=r"invalid package name '\.\.': it is not letters"):
        resolve_uri("package://../x.urdf", base_dir=tmp_path)
