"""Hypothesis: a state machine over the ops and a malformed-frame fuzzer. The bridge never
raises, every bad frame gets exactly one error status, and a second well-behaved client
keeps receiving everything published to it."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule
from websockets.asyncio.client import connect

from harness.rosbridge import Bridge, BridgeServer, TypeRegistry
from tests.rosbridge.helpers import recv_json, send_json, wait_for

REGISTRY = TypeRegistry()
TOPICS = st.sampled_from(["/a", "/b", "c", "/good"])
TYPES = st.sampled_from(["std_msgs/String", "std_msgs/msg/Int32", "geometry_msgs/Point", "bad", ""])
OPS = st.sampled_from(
    [
        "advertise",
        "unadvertise",
        "publish",
        "subscribe",
        "unsubscribe",
        "call_service",
        "service_response",
        "advertise_service",
        "send_action_goal",
        "cancel_action_goal",
        "fragment",
        "set_level",
        "status",
        "nope",
    ]
)
JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=False)
    | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)
FRAMES = st.one_of(
    st.text(max_size=40),
    st.binary(max_size=40),
    st.builds(json.dumps, JSON),
    st.builds(
        lambda op, extra: json.dumps({"op": op, **extra}),
        OPS,
        st.dictionaries(
            st.sampled_from(
                [
                    "topic",
                    "type",
                    "msg",
                    "id",
                    "service",
                    "args",
                    "action",
                    "level",
                    "data",
                    "num",
                    "total",
                    "values",
                ]
            ),
            JSON,
            max_size=4,
        ),
    ),
)


def good_message(i: int) -> dict[str, Any]:
    return {"op": "publish", "topic": "/good", "msg": {"data": f"GOOD#{i}"}}


class BridgeMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.bridge = Bridge(REGISTRY)
        self.fuzzer = self.bridge.connect()
        self.good = self.bridge.connect()
        self.bridge.receive(
            self.good,
            json.dumps({"op": "subscribe", "topic": "/good", "type": "std_msgs/String"}),
            0,
        )
        self.bridge.receive(
            self.good,
            json.dumps({"op": "advertise", "topic": "/good", "type": "std_msgs/String"}),
            0,
        )
        self.published = 0
        self.received: list[str] = []
        self.now = 0

    def _feed(self, conn: int, frame: str | bytes) -> list[Any]:
        self.now += 1
        outs = self.bridge.receive(conn, frame, self.now)
        for o in outs:
            assert o.connection in (self.fuzzer, self.good)
            if o.connection == self.good:
                assert isinstance(o.data, str), "binary frame to a client that did not ask for CBOR"
                f = json.loads(o.data)
                if f["op"] == "publish" and f["topic"] == "/good":
                    self.received.append(f["msg"]["data"])
        return [o for o in outs if o.connection == self.fuzzer]

    @rule(
        op=OPS,
        topic=TOPICS,
        type_=TYPES,
        msg=JSON,
        id_=st.none() | st.text(max_size=3) | st.integers(0, 3),
    )
    def op(self, op: str, topic: str, type_: str, msg: Any, id_: Any) -> None:
        frame: dict[str, Any] = {
            "op": op,
            "topic": topic,
            "type": type_,
            "msg": msg,
            "service": topic,
            "action": topic,
        }
        if id_ is not None:
            frame["id"] = id_
        self._feed(self.fuzzer, json.dumps(frame))

    @rule(frame=FRAMES)
    def malformed(self, frame: str | bytes) -> None:
        self._feed(self.fuzzer, frame)

    @rule(
        frame=st.sampled_from(
            ["{", "[]", '{"op": 3}', '{"op": "publish"}', '{"op":"subscribe","topic":5}', b"\xff"]
        )
    )
    def surely_bad(self, frame: str | bytes) -> None:
        out = self._feed(self.fuzzer, frame)
        statuses = [json.loads(o.data) for o in out if o.op == "status"]
        # set_level none may have silenced it; otherwise exactly one error status
        if self.bridge._conns[self.fuzzer].level <= 2:
            assert [s["level"] for s in statuses] == ["error"], out

    @rule()
    def good_publish(self) -> None:
        self._feed(self.good, json.dumps(good_message(self.published)))
        self.published += 1

    @invariant()
    def good_client_got_everything(self) -> None:
        # the fuzzer may publish on /good too; the good client's own messages all arrive, in order
        mine = [m for m in self.received if m.startswith("GOOD#")]
        assert mine == [f"GOOD#{i}" for i in range(self.published)]


BridgeMachine.TestCase.settings = settings(max_examples=60, stateful_step_count=30, deadline=None)
TestBridgeMachine = pytest.mark.slow(BridgeMachine.TestCase)


@settings(max_examples=15, deadline=None)
@given(frames=st.lists(FRAMES, min_size=1, max_size=8))
@pytest.mark.slow
def test_server_survives_malformed_frames_over_websocket(frames: list[str | bytes]) -> None:
    async def main() -> None:
        async with (
            BridgeServer() as server,
            connect(server.url) as bad,
            connect(server.url) as good,
        ):
            await send_json(good, {"op": "subscribe", "topic": "/good", "type": "std_msgs/String"})
            await wait_for(lambda: server.bridge.subscribers_of("/good") != [])
            for frame in frames:
                await bad.send(frame)
                server.bridge.publish("/good", "std_msgs/String", {"data": "tick"}, 0)
            server.flush()
            for _ in frames:
                assert (await recv_json(good)) == {
                    "op": "publish",
                    "topic": "/good",
                    "msg": {"data": "tick"},
                }
            await send_json(
                bad, {"op": "call_service", "service": "/rosapi/get_ros_version", "id": "alive"}
            )
            while True:  # the fuzzer's connection still works after everything it sent
                reply = await asyncio.wait_for(bad.recv(), 5)
                if isinstance(reply, str) and json.loads(reply).get("id") == "alive":
                    break

    asyncio.run(asyncio.wait_for(main(), 30))
