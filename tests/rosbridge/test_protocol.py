"""The sans-I/O core: frames in, frames out, for every op and every error case."""

from __future__ import annotations

import base64
import json
import math
import zlib
from typing import Any

import cbor2
import numpy as np
import pytest
from rosbags.typesys import Stores

from harness.rosbridge import DEFERRED, Bridge, ServiceCall, TapRecord, TypeRegistry
from harness.rosbridge.errors import TypeNameError, UnknownTypeError
from harness.rosbridge.types import parse_type_name
from tests.rosbridge.helpers import install_test_graph

REGISTRY = TypeRegistry()  # parsing the bundled definitions once keeps the suite fast


class Wire:
    """A bridge with helpers: send a frame (dict or text), get parsed (connection, frame)."""

    def __init__(self, **kwargs: Any) -> None:
        self._taps: list[TapRecord] = []
        self.bridge = Bridge(REGISTRY, keep_frames=True, **kwargs)
        install_test_graph(self.bridge)

    @property
    def taps(self) -> list[TapRecord]:
        """Every frame the bridge kept so far (drained from it into one list)."""
        self._taps += self.bridge.frames()
        return self._taps

    def connect(self) -> int:
        return self.bridge.connect()

    def send(self, conn: int, frame: Any, now_ns: int = 0) -> list[tuple[int, Any]]:
        data = frame if isinstance(frame, (str, bytes)) else json.dumps(frame)
        return [
            (o.connection, self._parse(o.data)) for o in self.bridge.receive(conn, data, now_ns)
        ]

    def drain(self) -> list[tuple[int, Any]]:
        return [(o.connection, self._parse(o.data)) for o in self.bridge.drain()]

    @staticmethod
    def _parse(data: str | bytes) -> Any:
        return cbor2.loads(data) if isinstance(data, bytes) else json.loads(data)

    def error(self, conn: int, frame: Any) -> str:
        out = self.send(conn, frame)
        assert [(c, f["op"], f["level"]) for c, f in out] == [(conn, "status", "error")], out
        return str(out[0][1]["msg"])


@pytest.fixture
def wire() -> Wire:
    return Wire()


def pubsub(wire: Wire, type_: str = "std_msgs/String", topic: str = "/t") -> tuple[int, int]:
    a, b = wire.connect(), wire.connect()
    assert wire.send(a, {"op": "subscribe", "topic": topic, "type": type_}) == []
    assert wire.send(b, {"op": "advertise", "topic": topic, "type": type_}) == []
    return a, b


# -- envelope and errors -------------------------------------------------------------------


def test_publish_reaches_subscriber_with_exact_frame(wire: Wire) -> None:
    a, b = pubsub(wire)
    out = wire.bridge.receive(b, '{"op":"publish","id":"p1","topic":"/t","msg":{"data":"hi"}}', 0)
    assert [(o.connection, o.data) for o in out] == [
        (a, '{"op":"publish","topic":"/t","msg":{"data":"hi"}}')
    ]


def test_several_objects_in_one_frame_are_processed_in_order(wire: Wire) -> None:
    _a, b = pubsub(wire)
    text = (
        '{"op":"publish","topic":"/t","msg":{"data":"1"}} '
        '{"op":"publish","topic":"/t","msg":{"data":"2"}}'
    )
    assert [f["msg"]["data"] for _, f in wire.send(b, text)] == ["1", "2"]


def test_binary_frame_is_read_as_utf8_json(wire: Wire) -> None:
    a, b = pubsub(wire)
    out = wire.send(b, b'{"op":"publish","topic":"/t","msg":{"data":"bin"}}')
    assert out == [(a, {"op": "publish", "topic": "/t", "msg": {"data": "bin"}})]
    assert "not UTF-8" in wire.error(b, b"\xff\xfe")


@pytest.mark.parametrize(
    ("frame", "expected"),
    [
        ("not json", "Invalid JSON: Expecting value at char 0"),
        ("", "Invalid JSON: empty frame"),
        ("[1, 2]", "Expected a JSON object, got a list"),
        ({"id": 1}, "Expected an op field but none was found."),
        ({"op": 5}, "Expected field op to be a string, got an int"),
        ({"op": "fly"}, "Unknown operation: fly"),
        (
            {"op": "advertise", "type": "std_msgs/String"},
            "advertise: Expected a topic field but none was found.",
        ),
        (
            {"op": "advertise", "topic": 5, "type": "std_msgs/String"},
            "advertise: Expected field topic to be a string, got an int (5)",
        ),
        (
            {"op": "advertise", "topic": "/t"},
            "advertise: Expected a type field but none was found.",
        ),
        (
            {"op": "advertise", "topic": "/t", "type": "bad"},
            "Invalid msg type 'bad': expected pkg/Type or pkg/msg/Type",
        ),
        (
            {"op": "advertise", "topic": "/t", "type": "nope_msgs/Foo"},
            "Unknown message type nope_msgs/msg/Foo",
        ),
        (
            {"op": "advertise", "topic": "a b", "type": "std_msgs/String"},
            "advertise: Invalid topic name 'a b'",
        ),
        (
            {"op": "publish", "topic": "/unknown", "msg": {}},
            "publish: Cannot infer topic type for topic /unknown as it is not yet advertised",
        ),
        (
            {"op": "publish", "topic": "/t", "msg": []},
            "publish: Expected field msg to be an object, got a list ([])",
        ),
        (
            {"op": "unadvertise", "topic": "/t"},
            "unadvertise: topic /t is not advertised by this client",
        ),
        ({"op": "unsubscribe", "topic": "/t"}, "unsubscribe: this client is not subscribed to /t"),
        (
            {"op": "subscribe", "topic": "/t", "throttle_rate": -1},
            "subscribe: field throttle_rate must be >= 0, got -1",
        ),
        (
            {"op": "subscribe", "topic": "/t", "queue_length": "x"},
            'subscribe: Expected field queue_length to be an int, got a string ("x")',
        ),
        (
            {"op": "set_level", "level": "loud"},
            "set_level: level must be one of info, warning, error, none; got 'loud'",
        ),
        (
            {"op": "service_response", "service": "/s", "id": "x"},
            "service_response: unknown service request id x for /s",
        ),
        (
            {"op": "unadvertise_service", "service": "/s"},
            "unadvertise_service: service /s is not advertised by this client",
        ),
        (
            {"op": "cancel_action_goal", "action": "/a", "id": "g"},
            "cancel_action_goal: no active goal with id g on /a",
        ),
        (
            {"op": "advertise_service", "service": "/rosapi/topics", "type": "rosapi_msgs/Topics"},
            "advertise_service: service /rosapi/topics is provided by the harness",
        ),
        (
            {"op": "advertise_service", "service": "/s", "type": "std_srvs/Nope"},
            "Unknown service type std_srvs/srv/Nope",
        ),
        (
            {"op": "advertise_action", "action": "/a", "type": "x/y/z/w"},
            "Invalid action type 'x/y/z/w': expected pkg/Type or pkg/action/Type",
        ),
        (
            {"op": "action_feedback", "action": "/a", "id": "g", "values": {}},
            "action_feedback: unknown goal id g for /a",
        ),
    ],
)
def test_bad_frames_get_an_error_status(wire: Wire, frame: Any, expected: str) -> None:
    c = wire.connect()
    assert wire.error(c, frame).startswith(expected)


def test_status_carries_the_client_id_and_connection_stays_usable(wire: Wire) -> None:
    a, b = pubsub(wire)
    out = wire.send(b, {"op": "publish", "id": "call-7", "topic": "/t", "msg": {"data": 5}})
    assert out == [
        (
            b,
            {
                "op": "status",
                "level": "error",
                "msg": "std_msgs/msg/String message requires a string for field data, "
                "but got an int (5)",
                "id": "call-7",
            },
        )
    ]
    assert wire.send(b, {"op": "publish", "topic": "/t", "msg": {"data": "ok"}})[0][0] == a


def test_id_must_be_string_or_int(wire: Wire) -> None:
    c = wire.connect()
    assert "id to be a string or an int" in wire.error(
        c, {"op": "set_level", "level": "info", "id": [1]}
    )


def test_set_level_none_silences_and_info_lets_warnings_through(wire: Wire) -> None:
    c = wire.connect()
    assert wire.send(c, {"op": "set_level", "level": "none"}) == []
    assert wire.send(c, "garbage") == []
    wire.send(c, {"op": "set_level", "level": "warning"})
    out = wire.send(c, {"op": "subscribe", "topic": "/untyped"})
    assert out[0][1]["level"] == "warning"
    assert "no type yet" in out[0][1]["msg"]


def test_type_conflict_is_reported_with_both_types(wire: Wire) -> None:
    a, _b = pubsub(wire)
    msg = wire.error(a, {"op": "advertise", "topic": "/t", "type": "std_msgs/msg/Int32"})
    assert msg == (
        "Tried to register topic /t with type std_msgs/msg/Int32 but it is already "
        "established with type std_msgs/msg/String"
    )
    assert wire.error(a, {"op": "subscribe", "topic": "/t", "type": "std_msgs/Int32"}) == msg


# -- types ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text", ["std_msgs/String", "std_msgs/msg/String", "/std_msgs//String/", "std_msgs/String/"]
)
def test_accepted_type_spellings(text: str) -> None:
    assert TypeRegistry(harness_msgs=False).resolve_message(text) == "std_msgs/msg/String"


@pytest.mark.parametrize(
    "text", ["", "/", "bad", "better/", "a/b/c", "std_msgs/srv/String", "1pkg/X", 5]
)
def test_invalid_type_spellings(text: Any) -> None:
    with pytest.raises(TypeNameError):
        parse_type_name(text, "msg")


def test_registry_knows_bundled_harness_and_user_types(tmp_path: Any) -> None:
    reg = TypeRegistry(Stores.ROS2_JAZZY)
    assert reg.resolve_service("std_srvs/SetBool") == "std_srvs/srv/SetBool"
    assert (
        reg.resolve_action("example_interfaces/Fibonacci") == "example_interfaces/action/Fibonacci"
    )
    assert reg.resolve_message("harness_msgs/BridgeFrame") == "harness_msgs/msg/BridgeFrame"
    assert reg.resolve_service("harness_msgs/srv/Step") == "harness_msgs/srv/Step"
    path = tmp_path / "my_pkg" / "action" / "Move.action"
    path.parent.mkdir(parents=True)
    path.write_text("float64 x\n---\nbool ok\n---\nfloat64 progress\n")
    assert reg.register_file(path) == "my_pkg/action/Move"
    assert [f.name for f in reg.message(reg.action("my_pkg/action/Move").feedback).fields] == [
        "progress"
    ]
    with pytest.raises(UnknownTypeError):
        reg.resolve_message("my_pkg/Nothing")


# -- message encoding ----------------------------------------------------------------------


def test_defaults_extra_fields_and_number_rules(wire: Wire) -> None:
    _a, b = pubsub(wire, "geometry_msgs/Point")
    assert wire.send(b, {"op": "publish", "topic": "/t", "msg": {"x": 1}})[0][1]["msg"] == {
        "x": 1.0,
        "y": 0.0,
        "z": 0.0,
    }
    assert wire.error(b, {"op": "publish", "topic": "/t", "msg": {"w": 1}}) == (
        "Message type geometry_msgs/msg/Point does not have a field w"
    )
    assert "requires a number (float64) for field x, but got a bool" in wire.error(
        b, {"op": "publish", "topic": "/t", "msg": {"x": True}}
    )
    _c, d = pubsub(wire, "std_msgs/Int32", "/i")
    assert "requires an int (int32) for field data, but got a float (1.5)" in wire.error(
        d, {"op": "publish", "topic": "/i", "msg": {"data": 1.5}}
    )
    assert "out of range for int32" in wire.error(
        d, {"op": "publish", "topic": "/i", "msg": {"data": 2**31}}
    )


def test_nan_and_inf_go_out_as_null(wire: Wire) -> None:
    _a, _b = pubsub(wire, "std_msgs/Float64MultiArray")
    wire.bridge.publish("/t", "std_msgs/Float64MultiArray", {"data": [math.nan, math.inf, 1.0]}, 0)
    assert wire.drain()[0][1]["msg"]["data"] == [None, None, 1.0]


def test_header_stamp_now_when_empty_and_zero_when_omitted(wire: Wire) -> None:
    _a, _b = pubsub(wire, "std_msgs/Header")
    _a2, b2 = pubsub(wire, "geometry_msgs/PointStamped", "/ps")
    out = wire.send(
        b2, {"op": "publish", "topic": "/ps", "msg": {"header": {}}}, now_ns=3_250_000_000
    )
    assert out[0][1]["msg"]["header"]["stamp"] == {"sec": 3, "nanosec": 250_000_000}
    out = wire.send(b2, {"op": "publish", "topic": "/ps", "msg": {}}, now_ns=3_250_000_000)
    assert out[0][1]["msg"]["header"]["stamp"] == {"sec": 0, "nanosec": 0}
    out = wire.send(
        b2, {"op": "publish", "topic": "/ps", "msg": {"header": {"stamp": {"secs": 4, "nsecs": 5}}}}
    )
    assert out[0][1]["msg"]["header"] == {"stamp": {"sec": 4, "nanosec": 5}, "frame_id": ""}


def test_byte_arrays_are_base64(wire: Wire) -> None:
    _a, b = pubsub(wire, "sensor_msgs/CompressedImage")
    out = wire.send(b, {"op": "publish", "topic": "/t", "msg": {"data": [1, 2, 255]}})
    assert out[0][1]["msg"]["data"] == base64.b64encode(bytes([1, 2, 255])).decode()
    out = wire.send(b, {"op": "publish", "topic": "/t", "msg": {"data": "AAEC"}})
    assert out[0][1]["msg"]["data"] == "AAEC"
    assert "base64" in wire.error(b, {"op": "publish", "topic": "/t", "msg": {"data": "@@"}})


def test_fixed_and_bounded_arrays_are_checked(wire: Wire) -> None:
    _a, b = pubsub(wire, "geometry_msgs/PoseWithCovariance")
    assert "needs exactly 36 elements, but got 2" in wire.error(
        b, {"op": "publish", "topic": "/t", "msg": {"covariance": [1, 2]}}
    )
    out = wire.send(b, {"op": "publish", "topic": "/t", "msg": {}})
    assert out[0][1]["msg"]["covariance"] == [0.0] * 36


# -- topics --------------------------------------------------------------------------------


def test_latched_message_reaches_late_subscribers(wire: Wire) -> None:
    p = wire.connect()
    wire.send(p, {"op": "advertise", "topic": "/l", "type": "std_msgs/String", "latch": True})
    wire.send(p, {"op": "publish", "topic": "/l", "msg": {"data": "kept"}})
    for _ in range(3):
        s = wire.connect()
        assert wire.send(s, {"op": "subscribe", "topic": "/l", "type": "std_msgs/String"}) == [
            (s, {"op": "publish", "topic": "/l", "msg": {"data": "kept"}})
        ]


def test_each_subscriber_gets_exactly_one_frame_and_own_messages(wire: Wire) -> None:
    subs = [wire.connect() for _ in range(3)]
    for s in subs:
        wire.send(s, {"op": "subscribe", "topic": "/m", "type": "std_msgs/String"})
        wire.send(s, {"op": "subscribe", "topic": "/m", "type": "std_msgs/String", "id": "second"})
    wire.send(subs[0], {"op": "advertise", "topic": "/m", "type": "std_msgs/String"})
    out = wire.send(subs[0], {"op": "publish", "topic": "/m", "msg": {"data": "x"}})
    assert sorted(c for c, _ in out) == subs


def test_publish_without_advertise_when_type_known(wire: Wire) -> None:
    a = wire.connect()
    wire.send(a, {"op": "subscribe", "topic": "/k", "type": "std_msgs/Bool"})
    assert wire.send(a, {"op": "publish", "topic": "/k"})[0][1]["msg"] == {"data": False}


def test_unadvertise_is_refcounted_by_id(wire: Wire) -> None:
    c = wire.connect()
    for i in ("a1", "a2"):
        wire.send(c, {"op": "advertise", "topic": "/r", "type": "std_msgs/String", "id": i})
    assert wire.send(c, {"op": "unadvertise", "topic": "/r", "id": "a1"}) == []
    assert wire.bridge.publishers_of("/r") == [c]
    assert "no advertisement with id a1" in wire.error(
        c, {"op": "unadvertise", "topic": "/r", "id": "a1"}
    )
    wire.send(c, {"op": "unadvertise", "topic": "/r", "id": "a2"})
    assert wire.bridge.publishers_of("/r") == []


def test_subscription_ids_and_effective_parameters(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "s2", "throttle_rate": 100})
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "s3", "throttle_rate": 50})
    # minimum throttle of the three is 0 (the first subscription): nothing throttled
    assert (
        len(
            wire.send(b, {"op": "publish", "topic": "/t"}, 0)
            + wire.send(b, {"op": "publish", "topic": "/t"}, 1)
        )
        == 2
    )
    # dropping the id-less subscription leaves the minimum of 100 ms and 50 ms
    assert wire.send(a, {"op": "unsubscribe", "topic": "/t", "id": None}) == []
    sent = [
        len(wire.send(b, {"op": "publish", "topic": "/t"}, ms * 1_000_000))
        for ms in (100, 120, 149, 150, 210)
    ]
    assert sent == [1, 0, 0, 1, 1]
    wire.send(a, {"op": "unsubscribe", "topic": "/t", "id": "s2"})
    assert "no subscription to /t with id s2" in wire.error(
        a, {"op": "unsubscribe", "topic": "/t", "id": "s2"}
    )
    wire.send(a, {"op": "unsubscribe", "topic": "/t"})
    assert wire.send(b, {"op": "publish", "topic": "/t"}, 10**12) == []


def test_queue_length_becomes_the_output_drop_limit(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "q", "queue_length": 3})
    (out,) = wire.bridge.receive(b, '{"op":"publish","topic":"/t"}', 0)
    assert out.queue_limit == 3
    c = wire.connect()
    wire.send(c, {"op": "subscribe", "topic": "/t", "queue_length": 0})
    outs = wire.bridge.receive(b, '{"op":"publish","topic":"/t"}', 0)
    assert [o.queue_limit for o in outs] == [3, wire.bridge.default_queue_length]


def test_png_compression(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "p", "compression": "png"})
    ((_, frame),) = wire.send(b, {"op": "publish", "topic": "/t", "msg": {"data": "compressed!"}})
    png = base64.b64decode(frame["data"])
    assert frame["op"] == "png"
    assert png.startswith(b"\x89PNG")
    idat = png[png.index(b"IDAT") + 4 : png.index(b"IEND") - 8]
    width = int.from_bytes(png[16:20], "big")
    rows = zlib.decompress(idat)
    pixels = b"".join(rows[i + 1 : i + 1 + width * 3] for i in range(0, len(rows), width * 3 + 1))
    assert json.loads(pixels.rstrip(b"\n")) == {
        "op": "publish",
        "topic": "/t",
        "msg": {"data": "compressed!"},
    }


def test_cbor_compression_uses_typed_arrays(wire: Wire) -> None:
    a, b = pubsub(wire, "sensor_msgs/JointState")
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "c", "compression": "cbor"})
    outs = wire.bridge.receive(
        b,
        json.dumps(
            {"op": "publish", "topic": "/t", "msg": {"name": ["j"], "position": [1.5, -2.0]}}
        ),
        0,
    )
    assert isinstance(outs[0].data, bytes)
    frame = cbor2.loads(outs[0].data)
    pos = frame["msg"]["position"]
    assert isinstance(pos, cbor2.CBORTag)
    assert pos.tag == 86
    assert np.frombuffer(pos.value, "<f8").tolist() == [1.5, -2.0]
    assert frame["msg"]["name"] == ["j"]


def test_cbor_raw_carries_cdr(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "r", "compression": "cbor-raw"})
    ((_, frame),) = wire.send(
        b, {"op": "publish", "topic": "/t", "msg": {"data": "raw"}}, now_ns=2_000_000_001
    )
    assert (frame["msg"]["secs"], frame["msg"]["nsecs"]) == (2, 1)
    store = wire.bridge.registry.store
    assert store.deserialize_cdr(frame["msg"]["bytes"], "std_msgs/msg/String").data == "raw"


def test_unknown_compression_means_none(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "z", "compression": "zip"})
    assert wire.send(b, {"op": "publish", "topic": "/t"})[0][1]["op"] == "publish"


# -- services ------------------------------------------------------------------------------


def test_call_missing_service_answers_like_the_reference(wire: Wire) -> None:
    c = wire.connect()
    assert wire.send(c, {"op": "call_service", "service": "x", "id": 9}) == [
        (
            c,
            {
                "op": "service_response",
                "service": "x",
                "values": "Service x does not exist",
                "result": False,
                "id": 9,
            },
        )
    ]


def test_call_in_process_service_with_positional_args(wire: Wire) -> None:
    c = wire.connect()
    assert wire.send(c, {"op": "call_service", "service": "/add_two_ints", "args": [2, 3]}) == [
        (
            c,
            {
                "op": "service_response",
                "service": "/add_two_ints",
                "values": {"sum": 5},
                "result": True,
            },
        )
    ]
    out = wire.send(
        c, {"op": "call_service", "service": "/add_two_ints", "args": {"a": "x"}, "id": 1}
    )
    assert out[0][1]["result"] is False
    assert "field a" in out[0][1]["values"]


def test_deferred_service_does_not_block_other_ops(wire: Wire) -> None:
    c = wire.connect()
    assert (
        wire.send(
            c, {"op": "call_service", "service": "/slow_add", "args": {"a": 1, "b": 1}, "id": "s"}
        )
        == []
    )
    wire.send(c, {"op": "subscribe", "topic": "/x", "type": "std_msgs/String"})
    assert (
        wire.send(c, {"op": "publish", "topic": "/x", "msg": {"data": "meanwhile"}})[0][1]["msg"][
            "data"
        ]
        == "meanwhile"
    )
    out = wire.send(c, {"op": "publish", "topic": "/tick", "msg": {}})
    assert out == [
        (
            c,
            {
                "op": "service_response",
                "service": "/slow_add",
                "values": {"sum": 2},
                "result": True,
                "id": "s",
            },
        )
    ]


def test_client_provided_service_routing_and_counter(wire: Wire) -> None:
    provider, caller = wire.connect(), wire.connect()
    wire.send(
        provider,
        {"op": "advertise_service", "service": "/test_service", "type": "std_srvs/SetBool"},
    )
    out1 = wire.send(
        caller,
        {"op": "call_service", "service": "/test_service", "args": {"data": True}, "id": "c1"},
    )
    out2 = wire.send(caller, {"op": "call_service", "service": "/test_service", "id": "c2"})
    assert out1 == [
        (
            provider,
            {
                "op": "call_service",
                "id": "service_request:/test_service:1",
                "service": "/test_service",
                "args": {"data": True},
            },
        )
    ]
    assert out2[0][1]["id"] == "service_request:/test_service:2"
    # answered out of order, routed by id
    r2 = wire.send(
        provider,
        {
            "op": "service_response",
            "service": "/test_service",
            "id": "service_request:/test_service:2",
            "values": {"message": "two"},
            "result": True,
        },
    )
    r1 = wire.send(
        provider,
        {
            "op": "service_response",
            "service": "/test_service",
            "id": "service_request:/test_service:1",
            "values": {"success": True, "message": "one"},
            "result": True,
        },
    )
    assert r2 == [
        (
            caller,
            {
                "op": "service_response",
                "service": "/test_service",
                "values": {"success": False, "message": "two"},
                "result": True,
                "id": "c2",
            },
        )
    ]
    assert r1[0][1]["values"] == {"success": True, "message": "one"}
    # re-advertising restarts the counter
    wire.send(provider, {"op": "unadvertise_service", "service": "/test_service"})
    wire.send(
        provider,
        {"op": "advertise_service", "service": "/test_service", "type": "std_srvs/SetBool"},
    )
    assert (
        wire.send(caller, {"op": "call_service", "service": "/test_service"})[0][1]["id"]
        == "service_request:/test_service:1"
    )


def test_bad_service_response_fails_the_call_and_tells_the_provider(wire: Wire) -> None:
    provider, caller = wire.connect(), wire.connect()
    wire.send(provider, {"op": "advertise_service", "service": "/s", "type": "std_srvs/Trigger"})
    wire.send(caller, {"op": "call_service", "service": "/s", "id": 1})
    out = wire.send(
        provider,
        {
            "op": "service_response",
            "service": "/s",
            "id": "service_request:/s:1",
            "values": {"success": 3},
        },
    )
    by_conn = {c: f for c, f in out}
    assert by_conn[caller]["result"] is False
    assert "field success" in by_conn[caller]["values"]
    assert by_conn[provider]["op"] == "status"


def test_provider_disconnect_and_timeout_fail_pending_calls(wire: Wire) -> None:
    wire.bridge.deadlines()  # kept from now on
    provider, caller = wire.connect(), wire.connect()
    wire.send(provider, {"op": "advertise_service", "service": "/s", "type": "std_srvs/Trigger"})
    wire.send(caller, {"op": "call_service", "service": "/s", "id": 1, "timeout": 0.5})
    wire.send(caller, {"op": "call_service", "service": "/s", "id": 2})
    started = wire.bridge.deadlines()
    assert [t for _, t in started] == [0.5, wire.bridge.call_timeout_s]
    out = [
        (c, json.loads(o.data))
        for o in wire.bridge.time_out_call(started[0][0])
        for c in [o.connection]
    ]
    assert out == [
        (
            caller,
            {
                "op": "service_response",
                "service": "/s",
                "values": "Service /s timed out",
                "result": False,
                "id": 1,
            },
        )
    ]
    assert wire.bridge.time_out_call(started[0][0]) == []
    out = [(o.connection, json.loads(o.data)) for o in wire.bridge.disconnect(provider)]
    assert out == [
        (
            caller,
            {
                "op": "service_response",
                "service": "/s",
                "values": "Service /s provider disconnected",
                "result": False,
                "id": 2,
            },
        )
    ]


def test_handler_exception_answers_with_failure(wire: Wire) -> None:
    def broken(call: ServiceCall) -> object:
        raise RuntimeError("boom")

    wire.bridge.advertise_service("/broken", "std_srvs/Trigger", broken)
    c = wire.connect()
    out = wire.send(c, {"op": "call_service", "service": "/broken"})
    assert out[0][1]["values"] == "Service /broken handler raised RuntimeError: boom"


# -- actions -------------------------------------------------------------------------------


def test_in_process_action_feedback_and_result(wire: Wire) -> None:
    c = wire.connect()
    out = wire.send(
        c,
        {
            "op": "send_action_goal",
            "id": "g1",
            "action": "/fibonacci",
            "action_type": "example_interfaces/action/Fibonacci",
            "args": {"order": 5},
            "feedback": True,
        },
    )
    ops = [f["op"] for _, f in out]
    assert ops == ["action_feedback"] * 4 + ["action_result"]
    assert out[-1][1] == {
        "op": "action_result",
        "action": "/fibonacci",
        "values": {"sequence": [0, 1, 1, 2, 3, 5]},
        "status": 4,
        "result": True,
        "id": "g1",
    }
    without = wire.send(
        c, {"op": "send_action_goal", "id": "g2", "action": "/fibonacci", "args": {"order": 2}}
    )
    assert [f["op"] for _, f in without] == ["action_result"]


def test_missing_action_and_cancel(wire: Wire) -> None:
    c = wire.connect()
    assert wire.send(
        c,
        {
            "op": "send_action_goal",
            "id": "g",
            "action": "/none",
            "action_type": "example_interfaces/action/Fibonacci",
        },
    ) == [
        (
            c,
            {
                "op": "action_result",
                "action": "/none",
                "values": "Action /none does not exist",
                "status": 0,
                "result": False,
                "id": "g",
            },
        )
    ]
    assert (
        wire.send(
            c,
            {
                "op": "send_action_goal",
                "id": "s",
                "action": "/slow_fibonacci",
                "args": {"order": 3},
            },
        )
        == []
    )
    out = wire.send(c, {"op": "cancel_action_goal", "id": "s", "action": "/slow_fibonacci"})
    assert out[0][1]["status"] == 5
    assert out[0][1]["id"] == "s"


def test_client_provided_action(wire: Wire) -> None:
    server, client = wire.connect(), wire.connect()
    wire.send(
        server,
        {"op": "advertise_action", "action": "/fib", "type": "example_interfaces/action/Fibonacci"},
    )
    out = wire.send(
        client,
        {
            "op": "send_action_goal",
            "id": "mine",
            "action": "/fib",
            "action_type": "example_interfaces/Fibonacci",
            "args": {"order": 1},
            "feedback": True,
        },
    )
    assert out == [
        (
            server,
            {
                "op": "send_action_goal",
                "id": "action_goal:/fib:1",
                "action": "/fib",
                "action_type": "example_interfaces/action/Fibonacci",
                "args": {"order": 1},
                "feedback": True,
            },
        )
    ]
    fb = wire.send(
        server,
        {
            "op": "action_feedback",
            "action": "/fib",
            "id": "action_goal:/fib:1",
            "values": {"partial_sequence": [0]},
        },
    )
    assert fb == [
        (
            client,
            {
                "op": "action_feedback",
                "action": "/fib",
                "values": {"partial_sequence": [0]},
                "id": "mine",
            },
        )
    ]
    cancel = wire.send(client, {"op": "cancel_action_goal", "action": "/fib", "id": "mine"})
    assert cancel == [
        (server, {"op": "cancel_action_goal", "id": "action_goal:/fib:1", "action": "/fib"})
    ]
    res = wire.send(
        server,
        {
            "op": "action_result",
            "action": "/fib",
            "id": "action_goal:/fib:1",
            "values": {"sequence": [0]},
            "status": 5,
            "result": True,
        },
    )
    assert res == [
        (
            client,
            {
                "op": "action_result",
                "action": "/fib",
                "values": {"sequence": [0]},
                "status": 5,
                "result": True,
                "id": "mine",
            },
        )
    ]


# -- fragments -----------------------------------------------------------------------------


def test_incoming_fragments_reassemble_by_num(wire: Wire) -> None:
    a, b = pubsub(wire)
    text = json.dumps({"op": "publish", "topic": "/t", "msg": {"data": "fragmented"}})
    parts = [text[i : i + 10] for i in range(0, len(text), 10)]
    out: list[Any] = []
    for num in reversed(range(len(parts))):
        out += wire.send(
            b, {"op": "fragment", "id": "f", "data": parts[num], "num": num, "total": len(parts)}
        )
    assert out == [(a, {"op": "publish", "topic": "/t", "msg": {"data": "fragmented"}})]


def test_broken_fragments_are_reported(wire: Wire) -> None:
    c = wire.connect()
    assert "outside 0..total-1" in wire.error(
        c, {"op": "fragment", "id": 1, "data": "x", "num": 3, "total": 2}
    )
    wire.send(c, {"op": "fragment", "id": 2, "data": "{", "num": 0, "total": 2})
    assert "total 3 differs from 2" in wire.error(
        c, {"op": "fragment", "id": 2, "data": "}", "num": 1, "total": 3}
    )
    wire.send(c, {"op": "fragment", "id": 3, "data": "{", "num": 0, "total": 2})
    assert "is not valid: Invalid JSON" in wire.error(
        c, {"op": "fragment", "id": 3, "data": "!", "num": 1, "total": 2}
    )


def test_fragment_memory_is_bounded() -> None:
    wire = Wire(max_fragment_bytes=100, max_fragmented_messages=2)
    c = wire.connect()
    assert "exceed 100 bytes" in wire.error(
        c, {"op": "fragment", "id": 1, "data": "x" * 101, "num": 0, "total": 2}
    )
    wire.send(c, {"op": "fragment", "id": 2, "data": "x", "num": 0, "total": 2})
    wire.send(c, {"op": "fragment", "id": 3, "data": "x", "num": 0, "total": 2})
    assert "more than 2 incomplete" in wire.error(
        c, {"op": "fragment", "id": 4, "data": "x", "num": 0, "total": 2}
    )


def test_outgoing_fragments_have_integer_total(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(a, {"op": "subscribe", "topic": "/t", "id": "f", "fragment_size": 1024})
    out = wire.send(b, {"op": "publish", "topic": "/t", "msg": {"data": "x" * 2500}})
    frames = [f for _, f in out]
    assert all(
        f["op"] == "fragment" and isinstance(f["total"], int) and f["total"] == len(frames)
        for f in frames
    )
    assert (
        json.loads("".join(f["data"] for f in sorted(frames, key=lambda f: f["num"])))["msg"][
            "data"
        ]
        == "x" * 2500
    )


# -- rosapi --------------------------------------------------------------------------------


def call(wire: Wire, c: int, service: str, args: Any = None, now_ns: int = 0) -> Any:
    out = wire.send(c, {"op": "call_service", "service": service, "args": args or {}}, now_ns)
    assert out[0][1]["result"] is True, out
    return out[0][1]["values"]


def test_rosapi(wire: Wire) -> None:
    a, _b = pubsub(wire)
    assert call(wire, a, "/rosapi/topics") == {
        "topics": ["/t", "/tick"],
        "types": ["std_msgs/msg/String", "std_msgs/msg/Empty"],
    }
    assert call(wire, a, "rosapi/topics_for_type", {"type": "std_msgs/String"}) == {
        "topics": ["/t"]
    }
    assert call(wire, a, "/rosapi/topic_type", {"topic": "/t"}) == {"type": "std_msgs/msg/String"}
    raw = call(wire, a, "/rosapi/topics_and_raw_types")
    assert raw["typedefs_full_text"][0] == "string data\n"
    services = call(wire, a, "/rosapi/services")["services"]
    assert "/add_two_ints" in services
    assert "/rosapi/get_time" in services
    assert call(wire, a, "/rosapi/service_type", {"service": "/add_two_ints"}) == {
        "type": "example_interfaces/srv/AddTwoInts"
    }
    assert call(wire, a, "/rosapi/services_for_type", {"type": "std_srvs/Trigger"}) == {
        "services": []
    }
    assert call(wire, a, "/rosapi/nodes")["nodes"] == [
        "/harness",
        "/rosapi",
        "/rosbridge_websocket",
    ]
    details = call(wire, a, "/rosapi/node_details", {"node": "/rosbridge_websocket"})
    assert details == {"subscribing": ["/t"], "publishing": ["/t"], "services": []}
    assert call(wire, a, "/rosapi/action_servers")["action_servers"] == [
        "/fibonacci",
        "/slow_fibonacci",
    ]
    assert call(wire, a, "/rosapi/publishers", {"topic": "/t"}) == {
        "publishers": ["/rosbridge_websocket"]
    }
    assert call(wire, a, "/rosapi/get_time", now_ns=12_000_000_345) == {
        "time": {"sec": 12, "nanosec": 345}
    }
    assert call(wire, a, "/rosapi/get_ros_version") == {"version": 2, "distro": "humble"}
    typedefs = call(wire, a, "/rosapi/message_details", {"type": "harness_msgs/BridgeFrame"})[
        "typedefs"
    ]
    assert typedefs[0]["type"] == "harness_msgs/msg/BridgeFrame"
    assert "text" in typedefs[0]["fieldnames"]
    assert typedefs[0]["constnames"] == ["DIRECTION_IN", "DIRECTION_OUT"]
    req = call(wire, a, "/rosapi/service_request_details", {"type": "harness_msgs/Step"})[
        "typedefs"
    ]
    assert req[0]["fieldnames"] == ["steps", "until_topic", "until_count"]
    bad = wire.send(
        a, {"op": "call_service", "service": "/rosapi/message_details", "args": {"type": "no/Such"}}
    )
    assert bad[0][1]["result"] is False
    assert "Unknown message type no/msg/Such" in bad[0][1]["values"]


def test_rosapi_params(wire: Wire) -> None:
    c = wire.connect()
    assert call(wire, c, "/rosapi/has_param", {"name": "/p"}) == {"exists": False}
    call(wire, c, "/rosapi/set_param", {"name": "/p", "value": "[1, 2]"})
    assert call(wire, c, "/rosapi/get_param", {"name": "/p"}) == {"value": "[1, 2]"}
    assert call(wire, c, "/rosapi/get_param", {"name": "/q", "default_value": "3"}) == {
        "value": "3"
    }
    assert call(wire, c, "/rosapi/get_param_names") == {"names": ["/p"]}
    call(wire, c, "/rosapi/delete_param", {"name": "/p"})
    assert call(wire, c, "/rosapi/has_param", {"name": "/p"}) == {"exists": False}


# -- simulation side, tap, determinism -----------------------------------------------------


def test_in_process_publish_subscribe_and_call(wire: Wire) -> None:
    got: list[Any] = []
    wire.bridge.subscribe("/cmd", got.append, "std_msgs/Float64")
    c = wire.connect()
    wire.send(c, {"op": "publish", "topic": "/cmd", "msg": {"data": 2}})
    assert [(m.topic, m.type, m.msg, m.connection) for m in got] == [
        ("/cmd", "std_msgs/msg/Float64", {"data": 2.0}, c)
    ]
    wire.send(c, {"op": "subscribe", "topic": "/state", "type": "std_msgs/String"})
    wire.bridge.publish("/state", "std_msgs/String", {"data": "s"}, 5, latch=True)
    assert wire.drain() == [(c, {"op": "publish", "topic": "/state", "msg": {"data": "s"}})]
    answers: list[Any] = []
    wire.bridge.call_service(
        "/add_two_ints", {"a": 1, "b": 2}, lambda ok, v: answers.append((ok, v)), 0
    )
    wire.bridge.call_service("/none", {}, lambda ok, v: answers.append((ok, v)), 0)
    assert answers == [(True, {"sum": 3}), (False, "Service /none does not exist")]


def test_deferred_answer_goes_to_the_outbox(wire: Wire) -> None:
    calls: list[ServiceCall] = []
    wire.bridge.advertise_service(
        "/harness/step", "harness_msgs/srv/Step", lambda call: (calls.append(call), DEFERRED)[1]
    )
    c = wire.connect()
    assert (
        wire.send(
            c, {"op": "call_service", "service": "/harness/step", "args": {"steps": 3}, "id": 1}
        )
        == []
    )
    calls[0].respond({"sim_time": {"sec": 0, "nanosec": 3_000_000}})
    assert wire.drain() == [
        (
            c,
            {
                "op": "service_response",
                "service": "/harness/step",
                "values": {"sim_time": {"sec": 0, "nanosec": 3_000_000}},
                "result": True,
                "id": 1,
            },
        )
    ]


def test_tap_sees_every_frame_with_sequence_numbers(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.taps.clear()
    wire.send(b, '{"op":"publish","topic":"/t","msg":{"data":"x"}}')
    wire.send(b, "junk")
    seqs = [t.seq for t in wire.taps]
    assert seqs == list(range(seqs[0], seqs[0] + 4))
    assert [(t.connection, t.direction, t.op, t.name) for t in wire.taps] == [
        (b, 0, "publish", "/t"),
        (a, 1, "publish", "/t"),
        (b, 0, "", ""),
        (b, 1, "status", ""),
    ]
    assert wire.taps[0].data == '{"op":"publish","topic":"/t","msg":{"data":"x"}}'


def test_same_inputs_give_the_same_bytes() -> None:
    script = [
        (1, {"op": "subscribe", "topic": "/t", "type": "sensor_msgs/JointState"}),
        (
            2,
            {
                "msg": {"position": [1, 2], "name": ["a", "b"], "header": {}},
                "topic": "/t",
                "op": "publish",
            },
        ),
        (2, {"op": "call_service", "service": "/rosapi/topics", "id": "x"}),
        (
            1,
            {
                "op": "send_action_goal",
                "action": "/fibonacci",
                "args": {"order": 3},
                "feedback": True,
                "id": 4,
            },
        ),
    ]

    def run() -> tuple[list[Any], list[Any]]:
        wire = Wire()
        wire.connect(), wire.connect()
        wire.send(2, {"op": "advertise", "topic": "/t", "type": "sensor_msgs/JointState"})
        outs = [
            (o.connection, o.data)
            for c, f in script
            for o in wire.bridge.receive(c, json.dumps(f), 7)
        ]
        return outs, [(t.seq, t.connection, t.direction, t.data) for t in wire.taps]

    first, second = run(), run()
    assert first == second
    assert len(first[0]) == 1 + 1 + 3
    publish = next(d for c, d in first[0] if isinstance(d, str) and '"position"' in d)
    assert publish.index('"header"') < publish.index('"name"') < publish.index('"position"')


def test_disconnect_cleans_up(wire: Wire) -> None:
    a, b = pubsub(wire)
    wire.send(b, {"op": "advertise_service", "service": "/srv", "type": "std_srvs/Trigger"})
    wire.bridge.disconnect(b)
    assert wire.bridge.publishers_of("/t") == []
    assert "/srv" not in [s for s, _, _ in wire.bridge.services()]
    wire.bridge.disconnect(a)
    assert "/t" not in dict(wire.bridge.topics())
