"""Black-box WebSocket tests against the real server on 127.0.0.1 (the reference's own
websocket tests re-expressed), queued ingestion, backpressure and the client mode."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from websockets.asyncio.client import connect

from harness.rosbridge import BridgeClient, BridgeServer
from tests.rosbridge.helpers import make_server, recv_json, send_json, wait_for

STRING = "std_msgs/String"


def run(coro: Any) -> Any:
    return asyncio.run(asyncio.wait_for(coro, 30))


def test_smoke_ten_messages_each_way() -> None:
    async def main() -> None:
        async with make_server() as server:
            assert server.url.startswith("ws://127.0.0.1:")
            assert server.port > 0
            async with connect(server.url) as a, connect(server.url) as b:
                await send_json(a, {"op": "subscribe", "topic": "/b_to_a", "type": STRING})
                await send_json(b, {"op": "subscribe", "topic": "/a_to_b", "type": STRING})
                await send_json(a, {"op": "advertise", "topic": "/a_to_b", "type": STRING})
                await send_json(b, {"op": "advertise", "topic": "/b_to_a", "type": STRING})
                await wait_for(lambda: len(server.bridge.subscribers_of("/a_to_b")) == 1)
                for i in range(10):
                    await send_json(
                        a, {"op": "publish", "topic": "/a_to_b", "msg": {"data": f"a{i}"}}
                    )
                    await send_json(
                        b, {"op": "publish", "topic": "/b_to_a", "msg": {"data": f"b{i}"}}
                    )
                got_b = [await recv_json(b) for _ in range(10)]
                got_a = [await recv_json(a) for _ in range(10)]
                assert got_b == [
                    {"op": "publish", "topic": "/a_to_b", "msg": {"data": f"a{i}"}}
                    for i in range(10)
                ]
                assert got_a == [
                    {"op": "publish", "topic": "/b_to_a", "msg": {"data": f"b{i}"}}
                    for i in range(10)
                ]

    run(main())


def test_advertise_service_two_concurrent_calls_routed_by_id() -> None:
    async def main() -> None:
        async with (
            make_server() as server,
            connect(server.url) as provider,
            connect(server.url) as caller,
        ):
            await send_json(
                provider,
                {"op": "advertise_service", "service": "/test_service", "type": "std_srvs/SetBool"},
            )
            await wait_for(
                lambda: any(s == "/test_service" for s, _, _ in server.bridge.services())
            )
            await send_json(
                caller,
                {
                    "op": "call_service",
                    "service": "/test_service",
                    "args": {"data": True},
                    "id": "one",
                },
            )
            await send_json(
                caller,
                {
                    "op": "call_service",
                    "service": "/test_service",
                    "args": {"data": False},
                    "id": "two",
                },
            )
            r1, r2 = await recv_json(provider), await recv_json(provider)
            assert r1 == {
                "op": "call_service",
                "id": "service_request:/test_service:1",
                "service": "/test_service",
                "args": {"data": True},
            }
            for req in (r2, r1):
                await send_json(
                    provider,
                    {
                        "op": "service_response",
                        "service": "/test_service",
                        "id": req["id"],
                        "values": {"success": req["args"]["data"], "message": req["id"]},
                        "result": True,
                    },
                )
            answers = {
                f["id"]: f["values"] for f in [await recv_json(caller), await recv_json(caller)]
            }
            assert answers == {
                "one": {"success": True, "message": "service_request:/test_service:1"},
                "two": {"success": False, "message": "service_request:/test_service:2"},
            }

    run(main())


def test_transient_local_reaches_three_late_subscribers_and_action_goal() -> None:
    async def main() -> None:
        async with make_server() as server, connect(server.url) as pub:
            await send_json(
                pub, {"op": "advertise", "topic": "/latched", "type": STRING, "latch": True}
            )
            await send_json(pub, {"op": "publish", "topic": "/latched", "msg": {"data": "once"}})
            await send_json(
                pub,
                {
                    "op": "send_action_goal",
                    "id": "g",
                    "action": "/fibonacci",
                    "action_type": "example_interfaces/action/Fibonacci",
                    "args": {"order": 5},
                    "feedback": True,
                },
            )
            frames = [await recv_json(pub) for _ in range(5)]
            assert [f["op"] for f in frames] == ["action_feedback"] * 4 + ["action_result"]
            assert frames[-1]["status"] == 4
            for _ in range(3):
                async with connect(server.url) as late:
                    await send_json(late, {"op": "subscribe", "topic": "/latched", "type": STRING})
                    assert await recv_json(late) == {
                        "op": "publish",
                        "topic": "/latched",
                        "msg": {"data": "once"},
                    }

    run(main())


def test_queued_mode_applies_frames_only_when_drained_in_arrival_order() -> None:
    async def main() -> None:
        seen: list[tuple[str, int]] = []
        async with BridgeServer(queued=True) as server:
            server.bridge.subscribe(
                "/cmd", lambda m: seen.append((m.msg["data"], m.connection)), STRING
            )
            async with connect(server.url) as a, connect(server.url) as b:
                await send_json(a, {"op": "publish", "topic": "/cmd", "msg": {"data": "a1"}})
                await send_json(b, {"op": "publish", "topic": "/cmd", "msg": {"data": "b1"}})
                await send_json(a, {"op": "publish", "topic": "/cmd", "msg": {"data": "a2"}})
                await send_json(a, {"op": "call_service", "service": "/rosapi/get_time", "id": 1})
                await wait_for(lambda: len(server.pending()) == 4)
                frames = [json.loads(text) for _, text in server.pending()]
                arrival = [f["msg"]["data"] for f in frames if f["op"] == "publish"]
                assert seen == []
                assert server.process_pending(now_ns=7_000_000_000) == 4
                # applied in arrival order across connections, in send order per connection
                assert [d for d, _ in seen] == arrival
                assert [d for d, c in seen if c == 1] == ["a1", "a2"]
                assert (await recv_json(a))["values"] == {"time": {"sec": 7, "nanosec": 0}}

    run(main())


def test_slow_subscriber_drops_oldest_and_is_told() -> None:
    async def main() -> None:
        async with BridgeServer() as server, connect(server.url, max_queue=1) as slow:
            await send_json(slow, {"op": "set_level", "level": "warning"})
            await send_json(
                slow, {"op": "subscribe", "topic": "/fast", "type": STRING, "queue_length": 5}
            )
            await wait_for(lambda: server.bridge.subscribers_of("/fast") == [1])
            big = "x" * 200_000
            for i in range(200):
                server.bridge.publish("/fast", STRING, {"data": f"{i}:{big}"}, 0)
            server.flush()
            await wait_for(lambda: server.metrics[1].dropped.get("/fast", 0) > 0)
            frames = []
            while True:
                f = await recv_json(slow)
                frames.append(f)
                if f["op"] == "status":
                    break
            delivered = [
                int(f["msg"]["data"].split(":")[0]) for f in frames if f["op"] == "publish"
            ]
            assert delivered == sorted(delivered)
            assert delivered[-1] == 199
            dropped = server.metrics[1].dropped["/fast"]
            assert dropped + len(delivered) == 200
            assert f["level"] == "warning"
            assert "dropped" in f["msg"]
            assert "/fast" in f["msg"]

    run(main())


def test_too_large_frame_closes_only_that_client() -> None:
    async def main() -> None:
        async with (
            BridgeServer(max_size=1000) as server,
            connect(server.url) as ok,
            connect(server.url, max_size=None) as big,
        ):
            await send_json(ok, {"op": "subscribe", "topic": "/t", "type": STRING})
            await big.send(
                json.dumps({"op": "publish", "topic": "/t", "msg": {"data": "x" * 5000}})
            )
            await wait_for(lambda: len(server.connection_ids()) == 1)
            server.bridge.publish("/t", STRING, {"data": "still here"}, 0)
            server.flush()
            assert (await recv_json(ok))["msg"]["data"] == "still here"

    run(main())


def test_client_mode_reconnects_and_resubscribes() -> None:
    async def main() -> None:
        server = make_server()
        await server.start()
        port = server.port
        got: list[Any] = []
        async with BridgeClient(server.url, reconnect_delay=0.05) as client:
            await client.subscribe("/chatter", STRING, got.append)
            await client.advertise("/chatter", STRING)
            assert await client.call_service("/add_two_ints", {"a": 20, "b": 22}) == {"sum": 42}
            await client.advertise_service(
                "/from_client", "std_srvs/Trigger", lambda args: {"success": True, "message": "hi"}
            )
            await wait_for(lambda: any(s == "/from_client" for s, _, _ in server.bridge.services()))
            assert await client.call_service("/from_client") == {"success": True, "message": "hi"}
            await client.publish("/chatter", {"data": "before"})
            await wait_for(lambda: len(got) == 1)
            await server.stop()
            await wait_for(lambda: not client.connected.is_set())
            server2 = make_server(port=port)
            await server2.start()
            try:
                await wait_for(lambda: client.reconnects == 1)
                await wait_for(lambda: server2.bridge.subscribers_of("/chatter") != [])
                await client.publish("/chatter", {"data": "after"})
                await wait_for(lambda: len(got) == 2)
                assert got == [{"data": "before"}, {"data": "after"}]
            finally:
                await server2.stop()

    run(main())
