"""Service-call and action-goal timeouts: a client's ``timeout`` is bounded (NaN and negative
refused, Infinity and 1e300 clamped to the cap), action goals time out too, deadlines live in
one heap (a flood of equal deadlines costs one loop timer) and go when either side leaves."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from websockets.asyncio.client import connect

from harness.rosbridge import Bridge, BridgeServer
from harness.rosbridge.deadlines import MAX_TIMEOUT_S, Deadlines
from harness.rosbridge.limits import MAX_PENDING_CALLS_PER_CLIENT


def _frames(outputs: list[Any]) -> list[tuple[int, dict[str, Any]]]:
    return [(o.connection, json.loads(o.data)) for o in outputs]


def _service_bridge() -> tuple[Bridge, int, int]:
    bridge = Bridge()
    bridge.deadlines()  # kept from now on
    provider, caller = bridge.connect(), bridge.connect()
    bridge.receive(
        provider,
        json.dumps({"op": "advertise_service", "service": "/s", "type": "std_srvs/Trigger"}),
        0,
    )
    return bridge, provider, caller


def _started(bridge: Bridge) -> list[tuple[int, float]]:
    return [(key, t) for key, t in bridge.deadlines() if t is not None]


def test_unbounded_service_timeouts_are_clamped_and_nan_refused() -> None:
    bridge, _, caller = _service_bridge()
    for i, timeout in enumerate(["Infinity", "1e300", "2.5"]):
        text = f'{{"op": "call_service", "service": "/s", "id": {i}, "timeout": {timeout}}}'
        bridge.receive(caller, text, 0)
    started = _started(bridge)
    assert [t for _, t in started] == [MAX_TIMEOUT_S, MAX_TIMEOUT_S, 2.5]
    for bad in ["NaN", "-1"]:
        text = f'{{"op": "call_service", "service": "/s", "id": "bad", "timeout": {bad}}}'
        out = _frames(bridge.receive(caller, text, 0))
        assert [(c, f["op"], f["level"]) for c, f in out] == [(caller, "status", "error")]
        assert "timeout must be a number of seconds >= 0" in out[0][1]["msg"]
    assert _started(bridge) == []  # the refused calls started nothing


def test_action_goals_time_out_and_are_canceled_at_the_server() -> None:
    bridge = Bridge()
    bridge.deadlines()  # kept from now on
    server, client = bridge.connect(), bridge.connect()
    fib = "example_interfaces/action/Fibonacci"
    bridge.receive(server, json.dumps({"op": "advertise_action", "action": "/f", "type": fib}), 0)
    goal = {"op": "send_action_goal", "action": "/f", "id": "g1", "args": {"order": 3}}
    bridge.receive(client, json.dumps(goal), 0)
    bridge.receive(client, json.dumps({**goal, "id": "g2", "timeout": 0.25}), 0)
    started = _started(bridge)
    assert [t for _, t in started] == [bridge.goal_timeout_s, 0.25]
    assert bridge.goal_timeout_s <= MAX_TIMEOUT_S
    out = _frames(bridge.time_out_call(started[1][0]))
    assert (client, "action_result", False, "Action /f timed out") in [
        (c, f["op"], f.get("result"), f.get("values")) for c, f in out
    ]
    assert (server, "cancel_action_goal") in [(c, f["op"]) for c, f in out]
    assert bridge.deadlines() == [(started[1][0], None)]
    bridge.disconnect(client)  # the other goal's deadline goes with its client
    assert bridge.deadlines() == [(started[0][0], None)]


def test_deadlines_heap_handles_equal_deadlines_and_stays_small() -> None:
    d = Deadlines()
    for key in range(100_000):
        d.add(key, float("inf") if key % 2 else 5.0)
    for key in range(0, 100_000, 2):
        if key % 4:
            d.cancel(key)
    assert len(d) == 75_000
    assert d.pop_due(4.9) == []
    assert d.pop_due(5.0) == list(range(0, 100_000, 4))
    for key in range(1, 100_000, 2):
        d.cancel(key)
    assert len(d) == 0
    assert d.next_deadline() is None
    assert len(d._heap) <= 128  # cancelled entries do not pile up


def test_timer_flood_uses_one_loop_timer_and_leaves_with_the_caller() -> None:
    async def main() -> None:
        async with BridgeServer(ping_interval=None) as server:
            loop = asyncio.get_running_loop()
            provider = await connect(server.url, compression=None, close_timeout=0.1)
            await provider.send(
                json.dumps({"op": "advertise_service", "service": "/s", "type": "std_srvs/Trigger"})
            )
            await provider.send(json.dumps({"op": "call_service", "service": "/rosapi/topics"}))
            await provider.recv()  # the advertisement has been processed
            caller = await connect(server.url, compression=None)
            n = MAX_PENDING_CALLS_PER_CLIENT - 1  # the fast call below is the last one allowed
            frames = "".join(
                f'{{"op": "call_service", "service": "/s", "id": {i}, "timeout": 1e300}}'
                for i in range(n)
            )
            await caller.send(frames)
            await caller.send(
                json.dumps({"op": "call_service", "service": "/s", "id": "fast", "timeout": 0.05})
            )
            answer = json.loads(await asyncio.wait_for(caller.recv(), 30))
            assert (answer["id"], answer["values"]) == ("fast", "Service /s timed out")
            assert len(server._deadlines) == n
            scheduled = len(loop._scheduled)  # type: ignore[attr-defined]
            assert scheduled < 20, scheduled
            await caller.close()
            for _ in range(10_000):
                if not server._deadlines:
                    break
                await asyncio.sleep(0)  # let the server see the close
            assert len(server._deadlines) == 0
            await provider.close()

    asyncio.run(main())
