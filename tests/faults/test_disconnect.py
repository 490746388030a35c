"""A client disconnecting mid-service-call and mid-action: the server and the other clients
carry on, and the pending call or goal is cleaned up (marked done, its provider told)."""

from __future__ import annotations

import asyncio
from typing import Any

from websockets.asyncio.client import connect

from harness.rosbridge import DEFERRED, ActionGoal, BridgeServer, ServiceCall
from harness.session import Session
from tests.faults.faultlib import recv, send, wait_until

TRIGGER = "std_srvs/srv/Trigger"
FIBONACCI = "example_interfaces/action/Fibonacci"


def _server() -> tuple[BridgeServer, list[ServiceCall], list[ActionGoal]]:
    server = BridgeServer(ping_interval=None)
    calls: list[ServiceCall] = []
    goals: list[ActionGoal] = []

    def slow(call: ServiceCall) -> object:
        calls.append(call)
        return DEFERRED

    def start_goal(goal: ActionGoal) -> None:
        goals.append(goal)
        goal.on_cancel = lambda g: g.finish({"sequence": []}, 5)

    server.bridge.advertise_service("/slow", TRIGGER, slow)
    server.bridge.advertise_action("/fib", FIBONACCI, start_goal)
    return server, calls, goals


async def _bystander_works(url: str, ws: Any) -> None:
    """The other client still gets what it subscribed to and can call services."""
    await send(ws, {"op": "publish", "topic": "/chatter", "msg": {"data": "still here"}})
    frame = await recv(ws, "publish")
    assert frame["msg"]["data"] == "still here"
    await send(ws, {"op": "call_service", "service": "/rosapi/topics", "id": "t"})
    assert (await recv(ws, "service_response"))["result"] is True


async def _bystander(url: str) -> Any:
    ws = await connect(url, compression=None)
    await send(ws, {"op": "advertise", "topic": "/chatter", "type": "std_msgs/msg/String"})
    await send(ws, {"op": "subscribe", "topic": "/chatter", "type": "std_msgs/msg/String"})
    return ws


def test_caller_disconnects_mid_service_call() -> None:
    async def main() -> None:
        server, calls, _ = _server()
        async with server:
            other = await _bystander(server.url)
            caller = await connect(server.url, compression=None)
            await send(caller, {"op": "call_service", "service": "/slow", "id": "1"})
            await wait_until(lambda: len(calls) == 1)
            assert not calls[0].done
            before = set(server.bridge.connections)
            await caller.close()
            await wait_until(lambda: len(server.bridge.connections) == len(before) - 1)
            assert calls[0].done  # the pending call was dropped with its caller
            calls[0].respond({"success": True, "message": "late"})  # no one to answer: no-op
            assert server.bridge.drain() == []
            await _bystander_works(server.url, other)
            # the service still works for the others
            await send(other, {"op": "call_service", "service": "/slow", "id": "2"})
            await wait_until(lambda: len(calls) == 2)
            calls[1].respond({"success": True, "message": "ok"})
            server.flush()  # in-process answers leave when their owner flushes
            answer = await recv(other, "service_response")
            assert answer["id"] == "2"
            assert answer["values"]["message"] == "ok"
            await other.close()

    asyncio.run(main())


def test_provider_disconnects_mid_service_call() -> None:
    async def main() -> None:
        server, _, _ = _server()
        async with server:
            other = await _bystander(server.url)
            provider = await connect(server.url, compression=None)
            await send(provider, {"op": "advertise_service", "service": "/remote", "type": TRIGGER})
            await send(other, {"op": "call_service", "service": "/remote", "id": "r"})
            request = await recv(provider, "call_service")
            assert request["service"] == "/remote"
            await provider.close()
            answer = await recv(other, "service_response")
            assert answer["id"] == "r"
            assert answer["result"] is False
            assert "disconnected" in str(answer["values"])
            await _bystander_works(server.url, other)
            await other.close()

    asyncio.run(main())


def test_caller_disconnects_mid_remote_service_call() -> None:
    """The provider's late answer to a caller that left is refused with a status, nothing
    else: the server and the other clients carry on."""

    async def main() -> None:
        server, _, _ = _server()
        async with server:
            other = await _bystander(server.url)
            provider = await connect(server.url, compression=None)
            await send(provider, {"op": "advertise_service", "service": "/remote", "type": TRIGGER})
            caller = await connect(server.url, compression=None)
            await send(caller, {"op": "call_service", "service": "/remote", "id": "c"})
            request = await recv(provider, "call_service")
            n = len(server.bridge.connections)
            await caller.close()
            await wait_until(lambda: len(server.bridge.connections) == n - 1)
            await send(
                provider,
                {
                    "op": "service_response",
                    "service": "/remote",
                    "id": request["id"],
                    "values": {"success": True, "message": "late"},
                    "result": True,
                },
            )
            status = await recv(provider, "status")
            assert "unknown service request id" in status["msg"]
            await _bystander_works(server.url, other)
            for ws in (provider, other):
                await ws.close()

    asyncio.run(main())


def test_caller_disconnects_mid_action() -> None:
    async def main() -> None:
        server, _, goals = _server()
        async with server:
            other = await _bystander(server.url)
            caller = await connect(server.url, compression=None)
            await send(
                caller,
                {"op": "send_action_goal", "action": "/fib", "action_type": FIBONACCI,
                 "args": {"order": 5}, "id": "g", "feedback": True},
            )  # fmt: skip
            await wait_until(lambda: len(goals) == 1)
            goals[0].feedback({"partial_sequence": [0, 1]})
            server.flush()
            assert (await recv(caller, "action_feedback"))["id"] == "g"
            n = len(server.bridge.connections)
            await caller.close()
            await wait_until(lambda: len(server.bridge.connections) == n - 1)
            assert goals[0].done
            assert goals[0].cancel_requested  # the action server is told to stop
            goals[0].feedback({"partial_sequence": [0, 1, 1]})  # nobody to send to: no-op
            goals[0].finish({"sequence": [0, 1, 1, 2]})
            assert server.bridge.drain() == []
            await _bystander_works(server.url, other)
            await other.close()

    asyncio.run(main())


def test_caller_disconnects_mid_remote_action() -> None:
    """A client-provided action server is sent ``cancel_action_goal`` for the goal of a
    caller that left."""

    async def main() -> None:
        server, _, _ = _server()
        async with server:
            other = await _bystander(server.url)
            provider = await connect(server.url, compression=None)
            await send(provider, {"op": "advertise_action", "action": "/rfib", "type": FIBONACCI})
            caller = await connect(server.url, compression=None)
            await send(
                caller,
                {"op": "send_action_goal", "action": "/rfib", "action_type": FIBONACCI,
                 "args": {"order": 3}, "id": "g"},
            )  # fmt: skip
            goal = await recv(provider, "send_action_goal")
            await caller.close()
            cancel = await recv(provider, "cancel_action_goal")
            assert cancel["id"] == goal["id"]
            assert cancel["action"] == "/rfib"
            await _bystander_works(server.url, other)
            for ws in (provider, other):
                await ws.close()

    asyncio.run(main())


def test_client_leaves_mid_step_call_in_a_session() -> None:
    """A client asks the Session for 500 steps and disconnects at once: the steps run, the
    answer goes nowhere, the session and another client carry on."""

    async def client(url: str) -> None:
        leaving = await connect(url, compression=None)
        await send(
            leaving,
            {"op": "call_service", "service": "/harness/step", "args": {"steps": 500}, "id": "s"},
        )
        await leaving.close()
        staying = await connect(url, compression=None)
        await send(
            staying,
            {"op": "call_service", "service": "/harness/step", "args": {"steps": 3}, "id": "t"},
        )
        answer = await recv(staying, "service_response")
        assert answer["result"] is True
        assert answer["id"] == "t"
        await staying.close()

    with Session("demo") as session:
        asyncio.run(client(session.url))
        assert session.failure is None
        assert session.step_index == 503
        assert session.step(2) == 505
