"""A client's publish relayed to client subscribers: the frames out and the frames kept for
the recording, whichever way each subscription asks for them (the relay's own path for
plain JSON subscriptions, fragmentation by subscription or by connection), and the string
fields every relayed message is checked for."""

from __future__ import annotations

import json

import pytest
from websockets.frames import Frame, Opcode

from harness.rosbridge import DIRECTION_IN, DIRECTION_OUT, Bridge, TypeRegistry
from harness.rosbridge.convert import from_json
from harness.rosbridge.errors import ConversionError
from harness.rosbridge.sending import frame_head


def test_relay_frames_and_taps_per_subscription_kind() -> None:
    bridge = Bridge(keep_frames=True)
    pub, plain, by_sub, by_conn, gone = (bridge.connect() for _ in range(5))
    advertise = {"op": "advertise", "topic": "/t", "type": "std_msgs/msg/String"}
    assert bridge.receive(pub, json.dumps(advertise), 0) == []
    sub = {"op": "subscribe", "topic": "/t"}
    bridge.receive(plain, json.dumps(sub), 0)
    bridge.receive(by_sub, json.dumps({**sub, "fragment_size": 1100}), 0)
    # a connection's fragment_size comes with any op but subscribe
    bridge.receive(
        by_conn, json.dumps({"op": "set_level", "level": "error", "fragment_size": 1030}), 0
    )
    bridge.receive(by_conn, json.dumps(sub), 0)
    bridge.receive(gone, json.dumps(sub), 0)
    bridge.disconnect(gone)
    bridge.frames()

    text = json.dumps({"op": "publish", "topic": "/t", "msg": {"data": "x" * 2500}})
    out = bridge.receive(pub, text, 7)
    expected = '{"op":"publish","topic":"/t","msg":{"data":"' + "x" * 2500 + '"}}'
    assert [(o.connection, o.op, o.name) for o in out[:1]] == [(plain, "publish", "/t")]
    assert out[0].data == expected
    assert out[0].queue_limit == bridge.default_queue_length
    for cid, size in ((by_sub, 1100), (by_conn, 1030)):
        frags = [json.loads(o.data) for o in out if o.connection == cid]
        assert len(frags) == -(-len(expected) // size)
        assert all(f["op"] == "fragment" and f["total"] == len(frags) for f in frags)
        assert "".join(f["data"] for f in frags) == expected
    taps = bridge.frames()
    assert taps[0] == (taps[0].seq, pub, DIRECTION_IN, text, "publish", "/t", 7)
    assert [
        (t.seq, t.connection, t.direction, t.data, t.op, t.name, t.now_ns) for t in taps[1:]
    ] == [
        (taps[0].seq + 1 + i, o.connection, DIRECTION_OUT, o.data, o.op, "/t", 7)
        for i, o in enumerate(out)
    ]
    assert bridge.seq == taps[-1].seq + 1


def test_relay_without_kept_frames_counts_the_same() -> None:
    kept, bare = Bridge(keep_frames=True), Bridge()
    for bridge in (kept, bare):
        a, b = bridge.connect(), bridge.connect()
        bridge.receive(
            a, json.dumps({"op": "advertise", "topic": "/t", "type": "std_msgs/String"}), 0
        )
        bridge.receive(b, json.dumps({"op": "subscribe", "topic": "/t"}), 0)
        bridge.receive(a, json.dumps({"op": "subscribe", "topic": "/t"}), 0)
        out = bridge.receive(
            a, json.dumps({"op": "publish", "topic": "/t", "msg": {"data": "hi"}}), 0
        )
        assert [o.connection for o in out] == [b, a]
    assert kept.seq == bare.seq == len(kept.frames())


REGISTRY = TypeRegistry()
REGISTRY.register("relay_test/msg/Strings", "string plain\nstring<=3 short\n")


def test_string_fields_take_any_str_and_bounded_ones_their_bound() -> None:
    msg = from_json(REGISTRY, "relay_test/msg/Strings", {"plain": "é" * 9, "short": "abc"}, 0)
    assert msg == {"plain": "é" * 9, "short": "abc"}
    assert from_json(REGISTRY, "relay_test/msg/Strings", {}, 0) == {"plain": "", "short": ""}
    with pytest.raises(ConversionError, match="longer than string<=3"):
        from_json(REGISTRY, "relay_test/msg/Strings", {"short": "abcd"}, 0)
    with pytest.raises(ConversionError, match="requires a string for field plain, but got an int"):
        from_json(REGISTRY, "relay_test/msg/Strings", {"plain": 3}, 0)


@pytest.mark.parametrize("length", [0, 1, 125, 126, 127, 65535, 65536, 70000])
@pytest.mark.parametrize("opcode", [Opcode.TEXT, Opcode.BINARY])
def test_frame_head_is_what_websockets_serializes(length: int, opcode: Opcode) -> None:
    payload = b"a" * length
    first = 0x80 | opcode.value
    assert frame_head(first, length) + payload == Frame(opcode, payload).serialize(mask=False)
