"""A session's type registry starts as a copy of a template; the messages a session compiles
from the template's own definitions are kept in the template, so the next session does not
compile them again. A definition a session registers itself stays its own."""

from __future__ import annotations

from rosbags.typesys import Stores

from harness.rosbridge import TypeRegistry


def test_messages_compiled_from_the_template_are_shared_with_the_next_registry() -> None:
    # a store no other test uses: its template is made by the first registry here
    TypeRegistry(Stores.ROS2_JAZZY, bundled=False, harness_msgs=False)
    first = TypeRegistry(Stores.ROS2_JAZZY, bundled=False, harness_msgs=False)
    tf = first.message("tf2_msgs/msg/TFMessage")
    second = TypeRegistry(Stores.ROS2_JAZZY, bundled=False, harness_msgs=False)
    assert second._compiled.get("tf2_msgs/msg/TFMessage") is tf
    assert second.message("tf2_msgs/msg/TFMessage") == tf


def test_a_definition_registered_by_one_registry_is_not_shared() -> None:
    TypeRegistry(Stores.ROS2_IRON, bundled=False, harness_msgs=False)  # the template
    own = TypeRegistry(Stores.ROS2_IRON, bundled=False, harness_msgs=False)
    own.register("my_pkg/msg/Thing", "int32 data\n")
    assert own.message("my_pkg/msg/Thing").fields[0].type == "int32"
    own.message("std_msgs/msg/String")
    fresh = TypeRegistry(Stores.ROS2_IRON, bundled=False, harness_msgs=False)
    assert "my_pkg/msg/Thing" not in fresh._compiled
    assert "std_msgs/msg/String" in fresh._compiled
