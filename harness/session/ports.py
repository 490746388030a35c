"""Where the session meets rosbridge: an embedded server (default) or a client of an external
server. Both are used only from the session's event loop thread."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Coroutine, Mapping
from typing import Any, Protocol

from harness.errors import BridgeError
from harness.rosbridge import BridgeClient, BridgeServer, TypeRegistry
from harness.rosbridge.convert import from_json
from harness.session.core import Graph, MessageCallback, ServiceHandler, SessionBridge
from harness.session.topics import HARNESS_NODE

__all__ = ["ClientPort", "Graph", "MessageCallback", "Port", "ServerPort", "ServiceHandler"]


class Port(Protocol):
    """The session shell's side of the transport: start, stop, and hand waiting input to the
    core at a step boundary."""

    @property
    def wake(self) -> asyncio.Event:
        """Set when input waits for :meth:`process_pending`."""
        ...

    async def start(self) -> str:
        """Serve or connect; returns the URL."""
        ...

    async def stop(self, on_input: Callable[[], object] | None = None) -> None:
        """Close every connection; until they are closed, ``on_input`` is called whenever
        input waits (:attr:`wake`), so the owner can process what still arrives."""
        ...

    async def settle(self) -> None:
        """Wait until subscriptions and services are registered."""
        ...

    def process_pending(self, now_ns: int) -> int:
        """Apply waiting input in arrival order at ``now_ns``; returns the frame count."""
        ...


class ServerPort:
    """The embedded rosbridge server around the core's :class:`SessionBridge`, in queued mode:
    frames wait until the session's step boundary (:meth:`process_pending`)."""

    def __init__(
        self, bridge: SessionBridge, *, host: str, port: int, token: str | None = None
    ) -> None:
        self.bridge = bridge
        self.server = BridgeServer(bridge, host=host, port=port, queued=True, token=token)

    @property
    def wake(self) -> asyncio.Event:
        return self.server.pending_event

    async def start(self) -> str:
        return await self.server.start()

    async def stop(self, on_input: Callable[[], object] | None = None) -> None:
        stopping = asyncio.ensure_future(self.server.stop())
        wake = self.server.pending_event
        while on_input is not None and not stopping.done():
            waiter = asyncio.ensure_future(wake.wait())
            await asyncio.wait({stopping, waiter}, return_when=asyncio.FIRST_COMPLETED)
            waiter.cancel()
            if wake.is_set():
                on_input()
        await stopping

    async def settle(self) -> None:
        """Registration is immediate in-process."""

    def process_pending(self, now_ns: int) -> int:
        return self.server.process_pending(now_ns)


class ClientPort:
    """A :class:`Graph` and :class:`Port` in one: a client of an external rosbridge server
    (the original framework's topology). Incoming messages apply when they arrive on the
    session's loop, which is always between steps. Frames are not tapped: a recording holds
    the published messages, not the bridge frames."""

    def __init__(self, url: str) -> None:
        self.client = BridgeClient(url)
        self.registry = TypeRegistry()
        self._wake = asyncio.Event()
        self._advertised: set[str] = set()
        self._last: asyncio.Future[None] | None = None
        self._now_ns = 0
        self.errors: list[str] = []
        """Incoming messages that did not match their type (nobody to tell)."""

    @property
    def wake(self) -> asyncio.Event:
        return self._wake

    async def start(self) -> str:
        await self.client.start()
        return self.client.url

    async def stop(self, on_input: Callable[[], object] | None = None) -> None:
        with contextlib.suppress(Exception):
            await self.settle()
        await self.client.close()

    async def settle(self) -> None:
        """Wait until every frame handed to the client so far is sent."""
        if self._last is not None:
            await self._last

    def process_pending(self, now_ns: int) -> int:
        self._now_ns = now_ns
        self._wake.clear()
        return 0

    def has_subscribers(self, topic: str) -> bool:
        return True

    def _send(self, coro: Coroutine[Any, Any, None]) -> None:
        """Send in call order: each send waits for the one before."""
        previous = self._last

        async def chained() -> None:
            if previous is not None:
                with contextlib.suppress(Exception):
                    await previous
            await coro

        self._last = asyncio.ensure_future(chained())

    def advertise(self, topic: str, type: str, *, node: str, latch: bool = False) -> None:
        """Advertise on the external server (whose graph names the node itself: ``node`` is
        not sent, here and in :meth:`subscribe`/:meth:`serve`)."""
        if topic not in self._advertised:
            self._advertised.add(topic)
            self._send(self.client.advertise(topic, type, latch=latch))

    def publish(
        self, topic: str, type: str, msg: Mapping[str, Any], now_ns: int, *, latch: bool = False
    ) -> None:
        if topic not in self._advertised:
            self._advertised.add(topic)
            self._send(self.client.advertise(topic, type, latch=latch))
        self._send(self.client.publish(topic, msg))

    def subscribe(
        self, topic: str, type: str, callback: MessageCallback, *, node: str = HARNESS_NODE
    ) -> None:
        def on_message(raw: dict[str, Any]) -> None:
            try:
                msg = from_json(self.registry, type, raw, self._now_ns)
            except BridgeError as exc:
                self.errors.append(f"{topic}: {exc}")
                return
            callback(msg, 0)

        self._send(self.client.subscribe(topic, type, on_message))

    def serve(
        self, service: str, type: str, handler: ServiceHandler, *, node: str = HARNESS_NODE
    ) -> None:
        async def answer(request: dict[str, Any]) -> Mapping[str, Any]:
            response = handler(request)
            await self.settle()  # what the call published goes out before its answer
            return response

        self._send(self.client.advertise_service(service, type, answer))

    def status(self, connection: int, level: str, text: str) -> None:
        """Status frames cannot reach the external server's clients: the log event remains."""
