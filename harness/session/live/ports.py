"""Where the session meets rosbridge: an embedded server (default) or, in client mode, a link
to an external server (:class:`~harness.session.live.upstream.UpstreamPort`). Both are used only
from the session's event loop thread."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Protocol

from harness.rosbridge import BridgeServer
from harness.session.core.bridge import Graph, MessageCallback, ServiceHandler, SessionBridge

__all__ = ["Graph", "MessageCallback", "Port", "ServerPort", "ServiceHandler"]


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

    def process_pending(self, now_ns: int, until: float | None = None) -> int:
        """Apply waiting input in arrival order at ``now_ns``; returns the frame count.
        ``until`` (:func:`time.monotonic`): a transport may stop early once it has passed and
        keep the rest, in order, for the next call."""
        ...

    def flush(self) -> None:
        """Send what the core's bridge produced outside :meth:`process_pending` (the owner
        calls it after its own calls into the core)."""
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

    def process_pending(self, now_ns: int, until: float | None = None) -> int:
        return self.server.process_pending(now_ns, until)

    def flush(self) -> None:
        self.server.flush()
