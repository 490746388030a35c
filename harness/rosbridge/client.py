"""Client mode: the harness as a client of an external rosbridge server (the topology of
the framework we succeed: the simulation connects out to a robot's rosbridge).

:class:`BridgeClient` keeps one WebSocket open, reconnects after a drop (``reconnect_delay``)
and re-sends its advertise, subscribe and advertise_service frames on every reconnect, as
roslibpy and roslibjs do. It speaks the same ops as the server; messages are plain dicts.
A call of the API whose frame cannot be sent raises; an answer to a call of a service it
provides that cannot be sent (the link dropped meanwhile) is counted in
:attr:`BridgeClient.send_failures` and logged (``harness.rosbridge.client``).
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
from collections.abc import Awaitable, Callable, Mapping
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI

from harness.rosbridge.errors import ClientError

__all__ = ["BridgeClient", "ServiceHandler"]

_log = logging.getLogger(__name__)

ServiceHandler = Callable[[dict[str, Any]], Mapping[str, Any] | Awaitable[Mapping[str, Any]]]


class BridgeClient:
    """A rosbridge v2 client with reconnect and re-subscription.

    Use as ``async with BridgeClient(url) as client:``; ``connected`` is set while a
    connection is up, ``reconnects`` counts successful reconnections.
    """

    def __init__(
        self, url: str, *, reconnect_delay: float = 0.2, max_size: int = 16 * 2**20
    ) -> None:
        self.url = url
        self.reconnect_delay = reconnect_delay
        self.max_size = max_size
        self.connected = asyncio.Event()
        self.reconnects = 0
        self.send_failures = 0
        """Service answers that could not be sent (the link dropped while serving)."""
        self.statuses: list[dict[str, Any]] = []
        self._ws: ClientConnection | None = None
        self._ids = itertools.count(1)
        self._setup: dict[tuple[str, str], dict[str, Any]] = {}
        self._callbacks: dict[str, list[Callable[[dict[str, Any]], None]]] = {}
        self._handlers: dict[str, ServiceHandler] = {}
        self._calls: dict[str, asyncio.Future[Any]] = {}
        self._task: asyncio.Task[None] | None = None
        self._closing = False
        self._serving: set[asyncio.Future[None]] = set()

    async def __aenter__(self) -> BridgeClient:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def start(self, timeout: float = 10.0) -> None:
        """Connect (retrying until ``timeout``) and start the receive loop."""
        self._task = asyncio.create_task(self._run())
        try:
            await asyncio.wait_for(self.connected.wait(), timeout)
        except asyncio.TimeoutError:
            await self.close()
            raise ClientError(f"could not connect to {self.url} within {timeout} s") from None

    async def close(self) -> None:
        """Close the connection and stop reconnecting."""
        self._closing = True
        if self._ws is not None:
            await self._ws.close()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        for fut in self._calls.values():
            if not fut.done():
                fut.set_exception(ClientError(f"client for {self.url} closed"))

    async def _run(self) -> None:
        first = True
        while not self._closing:
            try:
                async with connect(self.url, max_size=self.max_size, compression=None) as ws:
                    self._ws = ws
                    for frame in self._setup.values():
                        await ws.send(json.dumps(frame))
                    if not first:
                        self.reconnects += 1
                    first = False
                    self.connected.set()
                    async for message in ws:
                        await self._on_message(message)
            except (OSError, ConnectionClosed, InvalidHandshake, asyncio.TimeoutError):
                pass
            except InvalidURI as exc:
                raise ClientError(f"invalid rosbridge URL {self.url}: {exc}") from None
            self.connected.clear()
            self._ws = None
            for fut in self._calls.values():
                if not fut.done():
                    fut.set_exception(ClientError(f"connection to {self.url} lost during a call"))
            self._calls.clear()
            if not self._closing:
                await asyncio.sleep(self.reconnect_delay)

    async def _send(self, frame: Mapping[str, Any]) -> None:
        await self.connected.wait()
        assert self._ws is not None
        await self._ws.send(json.dumps(frame))

    async def _on_message(self, message: str | bytes) -> None:
        frame = json.loads(message)
        op = frame.get("op")
        if op == "publish":
            for cb in self._callbacks.get(frame["topic"], []):
                cb(frame["msg"])
        elif op == "service_response":
            fut = self._calls.pop(str(frame.get("id")), None)
            if fut is not None and not fut.done():
                if frame.get("result", True):
                    fut.set_result(frame.get("values"))
                else:
                    fut.set_exception(ClientError(f"{frame.get('service')}: {frame.get('values')}"))
        elif op == "call_service":
            handler = self._handlers.get(frame["service"])
            if handler is not None:
                task = asyncio.ensure_future(self._serve(handler, frame))
                self._serving.add(task)
                task.add_done_callback(self._serving.discard)
        elif op == "status":
            self.statuses.append(frame)

    async def _serve(self, handler: ServiceHandler, frame: dict[str, Any]) -> None:
        try:
            values = handler(frame.get("args", {}))
            if asyncio.iscoroutine(values) or isinstance(values, asyncio.Future):
                values = await values
            reply = {"values": dict(values), "result": True}  # type: ignore[arg-type]
        except Exception as exc:
            reply = {"values": f"{type(exc).__name__}: {exc}", "result": False}
        try:
            await self._send(
                {"op": "service_response", "service": frame["service"], "id": frame["id"], **reply}
            )
        except (ConnectionClosed, OSError) as exc:
            self.send_failures += 1
            _log.warning(
                "%s: could not answer %s (%s): %s",
                self.url, frame["service"], frame["id"], f"{type(exc).__name__}: {exc}",
            )  # fmt: skip

    # -- API ----------------------------------------------------------------------------

    async def advertise(self, topic: str, type: str, *, latch: bool = False) -> None:
        """Advertise ``topic``; re-sent after every reconnect."""
        frame = {
            "op": "advertise",
            "id": f"advertise:{topic}",
            "topic": topic,
            "type": type,
            "latch": latch,
        }
        self._setup[("advertise", topic)] = frame
        await self._send(frame)

    async def publish(self, topic: str, msg: Mapping[str, Any]) -> None:
        """Publish one message on an advertised topic."""
        await self._send({"op": "publish", "topic": topic, "msg": dict(msg)})

    async def subscribe(
        self, topic: str, type: str, callback: Callable[[dict[str, Any]], None], **options: Any
    ) -> None:
        """Call ``callback(msg)`` for every message on ``topic``; re-subscribed after every
        reconnect. ``options``: throttle_rate, queue_length, fragment_size."""
        self._callbacks.setdefault(topic, []).append(callback)
        frame = {
            "op": "subscribe",
            "id": f"subscribe:{topic}",
            "topic": topic,
            "type": type,
            **options,
        }
        self._setup[("subscribe", topic)] = frame
        await self._send(frame)

    async def call_service(
        self, service: str, args: Mapping[str, Any] | None = None, timeout: float = 10.0
    ) -> Any:
        """Call a service; returns its ``values`` or raises :class:`ClientError`."""
        call_id = f"call_service:{service}:{next(self._ids)}"
        fut: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self._calls[call_id] = fut
        await self._send(
            {"op": "call_service", "id": call_id, "service": service, "args": dict(args or {})}
        )
        try:
            return await asyncio.wait_for(fut, timeout)
        except asyncio.TimeoutError:
            self._calls.pop(call_id, None)
            raise ClientError(f"{service}: no answer within {timeout} s") from None

    async def advertise_service(self, service: str, type: str, handler: ServiceHandler) -> None:
        """Provide ``service``: ``handler(args)`` returns (or awaits) the response values."""
        self._handlers[service] = handler
        frame = {"op": "advertise_service", "service": service, "type": type}
        self._setup[("advertise_service", service)] = frame
        await self._send(frame)
