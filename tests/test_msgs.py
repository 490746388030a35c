"""The shipped harness_msgs definitions parse and register with rosbags' typestore."""

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from harness.msgs import definitions, message_definitions, service_definitions


def test_definitions_register_and_round_trip() -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in message_definitions().items():
        store.register(get_types_from_msg(text, name))
    frame_type = store.types["harness_msgs/msg/BridgeFrame"]
    import numpy as np

    frame = frame_type(
        step=7,
        sim_time_ns=7_000_000,
        direction=0,
        connection=1,
        seq=3,
        op="publish",
        topic="/chatter",
        binary=False,
        text='{"op":"publish"}',
        data=np.zeros(0, np.uint8),
    )
    raw = store.serialize_cdr(frame, "harness_msgs/msg/BridgeFrame")
    back = store.deserialize_cdr(bytes(raw), "harness_msgs/msg/BridgeFrame")
    assert (back.step, back.text, back.topic) == (7, '{"op":"publish"}', "/chatter")
    assert "harness_msgs/srv/Step" in service_definitions()
    assert set(definitions()) >= {"harness_msgs/msg/PhysicsState", "harness_msgs/srv/Step"}
