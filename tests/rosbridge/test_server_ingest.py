"""How the server takes in frames: messages handed over from the socket callback (WebSocket
fragments joined, bad UTF-8 refused), queued frames applied up to a deadline with the rest
kept in order, and reading paused while the queue is full."""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosedError

from harness.rosbridge import BridgeServer
from tests.rosbridge.helpers import recv_json, send_json, wait_for

STRING = "std_msgs/msg/String"


def run(coro: Any) -> Any:
    return asyncio.run(asyncio.wait_for(coro, 30))


def _publish(text: str) -> str:
    return json.dumps({"op": "publish", "topic": "/cmd", "msg": {"data": text}})


def test_a_deadline_stops_processing_and_keeps_the_rest_in_order() -> None:
    async def main() -> None:
        seen: list[str] = []
        async with BridgeServer(queued=True) as server:
            server.bridge.subscribe("/cmd", lambda m: seen.append(m.msg["data"]), STRING)
            async with connect(server.url) as ws:
                for i in range(5):
                    await ws.send(_publish(str(i)))
                await wait_for(lambda: len(server.pending()) == 5)
                # a deadline already past: one frame (at least one is always applied)
                assert server.process_pending(0, until=time.monotonic() - 1) == 1
                assert seen == ["0"]
                assert server.pending_event.is_set()  # the rest waits for the next boundary
                assert [json.loads(t)["msg"]["data"] for _, t in server.pending()] == list("1234")
                assert server.process_pending(0, until=time.monotonic() + 60) == 4
                assert seen == list("01234")
                assert not server.pending_event.is_set()

    run(main())


def test_fragmented_websocket_message_arrives_whole_and_bad_utf8_closes_1007() -> None:
    async def main() -> None:
        async with BridgeServer() as server:
            server.bridge.advertise("/cmd", STRING)
            async with connect(server.url) as ws:
                await send_json(ws, {"op": "subscribe", "topic": "/cmd", "type": STRING})
                text = _publish("x" * 3000)
                # three WebSocket frames (text, continuation, continuation): one message
                await ws.send([text[:1000], text[1000:2000], text[2000:]])
                frame = await recv_json(ws)
                assert frame["msg"]["data"] == "x" * 3000
                assert server.metrics[1].received == 2
            async with connect(server.url) as bad, connect(server.url) as good:
                # a text frame that is not UTF-8: sent raw, as a broken client would
                bad.protocol.send_text(b"\xff\xfe{}")  # the sans-I/O layer does not check
                bad.send_data()
                with pytest.raises(ConnectionClosedError) as closed:
                    await asyncio.wait_for(bad.recv(), 5)
                assert closed.value.rcvd is not None
                assert closed.value.rcvd.code == 1007
                # the other client keeps working
                await send_json(good, {"op": "call_service", "service": "/rosapi/get_time",
                                       "id": 1})  # fmt: skip
                assert (await recv_json(good))["op"] == "service_response"

    run(main())


def test_reading_pauses_while_the_queue_is_full_and_resumes_when_drained() -> None:
    async def main() -> None:
        seen: list[str] = []
        async with BridgeServer(queued=True, max_pending=1) as server:
            server.bridge.subscribe("/cmd", lambda m: seen.append(m.msg["data"]), STRING)
            async with connect(server.url) as ws:
                await ws.send(_publish("0"))
                await wait_for(lambda: len(server.pending()) == 1)
                for i in range(1, 6):
                    await ws.send(_publish(str(i)))
                while len(seen) < 6:  # each drain lets the next frames in
                    await wait_for(lambda: bool(server.pending()))
                    server.process_pending(0)
                assert seen == list("012345")

    run(main())
