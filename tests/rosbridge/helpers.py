"""Shared pieces of the rosbridge tests: a server with the in-process services and actions
the client scenarios use, and small waiting helpers (conditions, never sleeps)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable
from typing import Any

from websockets.asyncio.client import ClientConnection

from harness.rosbridge import DEFERRED, ActionGoal, Bridge, BridgeServer, ServiceCall

GOAL_CANCELED = 5


def install_test_graph(bridge: Bridge) -> None:
    """/add_two_ints (immediate), /slow_add (answers on the next /tick publish),
    /fibonacci (4-ish feedback frames then the result), /slow_fibonacci (until canceled)."""
    waiting: list[ServiceCall] = []

    def add(call: ServiceCall) -> dict[str, Any]:
        return {"sum": call.args["a"] + call.args["b"]}

    def slow_add(call: ServiceCall) -> object:
        waiting.append(call)
        return DEFERRED

    def tick(_msg: object) -> None:
        while waiting:
            call = waiting.pop(0)
            call.respond({"sum": call.args["a"] + call.args["b"]})

    def fibonacci(goal: ActionGoal) -> None:
        seq = [0, 1]
        for _ in range(1, goal.goal["order"]):
            seq.append(seq[-1] + seq[-2])
            goal.feedback({"partial_sequence": seq})
        goal.finish({"sequence": seq})

    def slow_fibonacci(goal: ActionGoal) -> None:
        goal.on_cancel = lambda g: g.finish({"sequence": [0]}, GOAL_CANCELED)

    bridge.advertise_service("/add_two_ints", "example_interfaces/srv/AddTwoInts", add)
    bridge.advertise_service("/slow_add", "example_interfaces/srv/AddTwoInts", slow_add)
    bridge.subscribe("/tick", tick, "std_msgs/msg/Empty")
    bridge.advertise_action("/fibonacci", "example_interfaces/action/Fibonacci", fibonacci)
    bridge.advertise_action(
        "/slow_fibonacci", "example_interfaces/action/Fibonacci", slow_fibonacci
    )


def make_server(**kwargs: Any) -> BridgeServer:
    """A server on a free port with the test graph installed."""
    server = BridgeServer(**kwargs)
    install_test_graph(server.bridge)
    return server


async def wait_for(condition: Callable[[], bool], timeout: float = 5.0) -> None:
    """Wait until ``condition()`` holds, yielding to the loop between checks."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while not condition():
        if loop.time() > deadline:
            raise AssertionError(f"condition not met within {timeout} s")
        await asyncio.sleep(0.005)


async def recv_json(ws: ClientConnection, timeout: float = 5.0) -> Any:
    """The next frame of ``ws`` parsed as JSON."""
    return json.loads(await asyncio.wait_for(ws.recv(), timeout))


async def send_json(ws: ClientConnection, frame: Any) -> None:
    await ws.send(json.dumps(frame))
