"""Client mode: the session as a client of an external rosbridge server (the original
framework's topology: ROS 2 nodes on DDS, a rosbridge server relaying, the simulator connected
to it as a client).

The session keeps its own :class:`~harness.session.core.bridge.SessionBridge`, exactly as in server
mode, and the link to the external server is one connection of it (the *upstream* connection).
So every frame is recorded, and replayed at ``--level full``, as a server-mode client's frames
are: what the external server sends (``publish`` of a command topic, ``call_service`` of a
``/harness/*`` service, ``status``) is handed to the bridge verbatim at a step boundary, and
what the bridge answers on that connection (``publish`` of the simulation's topics,
``service_response``) is sent on verbatim. To make the bridge route the simulation's topics to
the upstream connection, the port opens it with the frames a client would send: a
``subscribe`` for every topic the session publishes and an ``advertise`` for every topic it
subscribes to (recorded like any client's).

Towards the external server the port mirrors the session's graph (:func:`offer_of`): it
advertises every published topic (latched ones with ``latch``), subscribes to every command
topic, advertises every service and action. A round trip (a call of a service nobody
provides, answered by any rosbridge server) tells when the server has processed all of it;
an ``error`` status naming one of those frames fails the start with one line naming topic,
type and the server's reason (``allow_refused``: go on without what was refused). After the
server restarts the port reconnects, re-sends its set-up and latched messages, and records
the gap as transport status markers.

A frame the port cannot send (the link is down, or the send failed) is lost, as on any
rosbridge link; it is counted (:attr:`UpstreamStats.send_failures`), logged (``logging``
logger ``harness.session.live.upstream``) and reported: the first of each outage as a transport
status of the upstream connection (recorded as a ``harness/transport_status`` marker, so a
replay shows it where it happened), and how many were lost when the link is back.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI

from harness.rosbridge import OutgoingFrame
from harness.rosbridge.offer import Offer, offer_of
from harness.session.core.bridge import SessionBridge
from harness.session.errors import SessionError

__all__ = ["UpstreamError", "UpstreamPort", "UpstreamStats", "redact"]

_FORWARD = frozenset(
    {"publish", "service_response", "call_service", "fragment", "action_feedback", "action_result"}
)
"""Ops of the upstream connection's outputs that go to the external server (a ``status`` the
core sends its clients stays home: the server would call it an unknown op)."""
_log = logging.getLogger(__name__)
_SYNC = "harness:sync"
_WINDOW = 100
"""Frames sent before waiting for the server to have processed them (see ``_send_loop``)."""


class UpstreamError(SessionError):
    """The external rosbridge server refused the session (unreachable, or refused one of the
    simulation's own topics, services or actions)."""


@dataclass
class UpstreamStats:
    """What client mode counts: ``statuses`` the server sent by level, frames that could not
    be sent (``send_failures``: the link was down or the send failed; the last one's
    description in ``last_send_failure``), ``reconnects`` and what the server ``refused`` at
    the start (with ``allow_refused``)."""

    statuses: dict[str, int]
    send_failures: int = 0
    last_send_failure: str = ""
    reconnects: int = 0
    refused: tuple[str, ...] = ()

    def summary(self) -> str:
        """One line, e.g. ``status error 2, send failures 0, reconnects 1``."""
        levels = ", ".join(f"status {k} {v}" for k, v in sorted(self.statuses.items()))
        return (
            f"{levels + ', ' if levels else ''}send failures {self.send_failures}, "
            f"reconnects {self.reconnects}, refused {len(self.refused)}"
        )


def redact(url: str) -> str:
    """``url`` with the value of a ``token`` query parameter replaced by ``***``."""
    head, sep, query = url.partition("?")
    if not sep:
        return url
    parts = [
        "token=***" if p.startswith("token=") else p for p in query.split("&")
    ]  # fmt: skip
    return head + "?" + "&".join(parts)


class UpstreamPort:
    """A :class:`~harness.session.live.ports.Port` connecting the session's bridge to an external
    rosbridge server at ``url`` (a token goes in the URL). ``allow_refused``: start even when
    the server refuses some of the simulation's topics or services (they are left out and
    listed in :attr:`stats`); ``connect_timeout``: wall seconds to reach the server at the
    start; ``reconnect_delay``: wall seconds between reconnection attempts."""

    def __init__(
        self,
        bridge: SessionBridge,
        url: str,
        *,
        allow_refused: bool = False,
        connect_timeout: float = 10.0,
        reconnect_delay: float = 0.2,
        max_size: int = 16 * 2**20,
    ) -> None:
        self.bridge = bridge
        self.url = url
        self.allow_refused = allow_refused
        self.connect_timeout = connect_timeout
        self.reconnect_delay = reconnect_delay
        self.max_size = max_size
        self.stats = UpstreamStats(statuses={})
        self.connection: int | None = None
        """The upstream connection's id on the bridge (once :meth:`settle` opened it)."""
        self._wake = asyncio.Event()
        self._ws: ClientConnection | None = None
        self._connected = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._sender: asyncio.Task[None] | None = None
        self._outgoing: asyncio.Queue[str] = asyncio.Queue()
        self._pending: list[tuple[str, str]] = []  # ("frame", text) | ("link", text)
        self._setup: list[str] = []
        self._setup_ids: dict[str, str] = {}  # frame id -> "topic (type)"
        self._latched: dict[str, str] = {}  # topic -> last publish frame sent
        self._latched_topics: set[str] = set()
        self._refusals: list[str] = []
        self._syncs: dict[str, asyncio.Future[None]] = {}
        self._sync_count = 0
        self._setting_up = False
        self._closing = False
        self._lost = 0  # frames not sent since the current outage was reported

    # -- Port ------------------------------------------------------------------------

    @property
    def wake(self) -> asyncio.Event:
        return self._wake

    async def start(self) -> str:
        """Connect (retrying until ``connect_timeout``) and start receiving."""
        self._task = asyncio.ensure_future(self._run())
        self._sender = asyncio.ensure_future(self._send_loop())
        try:
            await asyncio.wait_for(asyncio.shield(self._connected.wait()), self.connect_timeout)
        except asyncio.TimeoutError:
            if self._task.done() and self._task.exception() is not None:
                raise self._task.exception() from None  # type: ignore[misc]
            raise UpstreamError(
                f"could not connect to the rosbridge server {redact(self.url)} within "
                f"{self.connect_timeout:g} s"
            ) from None
        return self.url

    async def settle(self) -> None:
        """Mirror the session's graph on the external server, wait until the server has
        processed it, fail on a refusal (unless ``allow_refused``), then open the upstream
        connection on the bridge."""
        offer = offer_of(self.bridge)
        refused = await self._set_up(offer)
        if refused and not self.allow_refused:
            more = f" (and {len(refused) - 1} more)" if len(refused) > 1 else ""
            raise UpstreamError(
                f"rosbridge server {redact(self.url)} refused {refused[0]}{more}; "
                "connect_allow_refused=True (--connect-allow-refused) runs without them"
            )
        self.stats.refused = tuple(refused)
        skip = {r.split(" ", 1)[0] for r in refused}
        self.connection = self.bridge.connect(f"upstream {redact(self.url)}")
        # every external client's traffic goes through this one connection: no send budget
        self.bridge.exempt_from_budget(self.connection)
        frames = [
            json.dumps({"op": "subscribe", "id": f"upstream:{t.name}", "topic": t.name,
                        "type": t.type})
            for t in offer.published if t.name not in skip
        ] + [
            json.dumps({"op": "advertise", "id": f"upstream:{t.name}", "topic": t.name,
                        "type": t.type})
            for t in offer.subscribed if t.name not in skip
        ]  # fmt: skip
        self._pending[:0] = [("frame", f) for f in frames]
        self._wake.set()

    def process_pending(self, now_ns: int, until: float | None = None) -> int:
        """Apply what the server sent (and link events) at this step boundary, in order
        (all of it: ``until`` is not used)."""
        self._wake.clear()
        if self.connection is None or not self._pending:
            return 0
        pending, self._pending = self._pending, []
        count = 0
        for kind, text in pending:
            if self.connection not in self.bridge.connections:
                break
            if kind == "link":
                self.bridge.transport_status(self.connection, "warning", text)
            else:
                for output in self.bridge.receive(self.connection, text, now_ns):
                    self._forward(output)
                count += 1
        self.flush()
        return count

    async def stop(self, on_input: Callable[[], object] | None = None) -> None:
        """Apply what already arrived, then close the link."""
        if on_input is not None and self._pending:
            on_input()
        self.flush()
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(self._outgoing.join(), 2.0)
        self._closing = True
        if self._ws is not None:
            with contextlib.suppress(Exception):
                await self._ws.close()
        for task in (self._task, self._sender):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task

    # -- set-up ----------------------------------------------------------------------

    async def _set_up(self, offer: Offer) -> list[str]:
        frames: list[dict[str, Any]] = []
        for t in offer.published:
            frames.append({"op": "advertise", "id": f"advertise:{t.name}", "topic": t.name,
                           "type": t.type, "latch": t.latched})  # fmt: skip
            self._setup_ids[f"advertise:{t.name}"] = f"{t.name} ({t.type})"
            if t.latched:
                self._latched_topics.add(t.name)
        for t in offer.subscribed:
            frames.append({"op": "subscribe", "id": f"subscribe:{t.name}", "topic": t.name,
                           "type": t.type})  # fmt: skip
            self._setup_ids[f"subscribe:{t.name}"] = f"{t.name} ({t.type})"
        for s in offer.services:
            frames.append({"op": "advertise_service", "id": f"advertise_service:{s.name}",
                           "service": s.name, "type": s.type})  # fmt: skip
            self._setup_ids[f"advertise_service:{s.name}"] = f"{s.name} ({s.type})"
        for a in offer.actions:
            frames.append({"op": "advertise_action", "id": f"advertise_action:{a.name}",
                           "action": a.name, "type": a.type})  # fmt: skip
            self._setup_ids[f"advertise_action:{a.name}"] = f"{a.name} ({a.type})"
        self._setup = [json.dumps(f) for f in frames]
        self._setting_up = True
        try:
            await self._send_setup()
            await self._round_trip()
        finally:
            self._setting_up = False
        return list(self._refusals)

    async def _send_setup(self) -> None:
        ws = self._ws
        if ws is None:
            return
        for text in self._setup:
            await ws.send(text)
        for text in self._latched.values():
            await ws.send(text)

    async def _round_trip(self, timeout: float = 10.0) -> None:
        """Wait until the server answered a call sent after everything sent so far (a
        rosbridge server processes a connection's frames in order): a call of a service nobody
        provides, answered by any server and never handed to the bridge."""
        ws = self._ws
        if ws is None:
            return
        self._sync_count += 1
        call = f"{_SYNC}:{self._sync_count}"
        done = self._syncs[call] = asyncio.get_running_loop().create_future()
        service = f"/harness/_sync_{self._sync_count}"
        frame = {"op": "call_service", "id": call, "service": service, "args": {}}
        try:
            await ws.send(json.dumps(frame))
            await asyncio.wait_for(done, timeout)
        except (asyncio.TimeoutError, ConnectionClosed, OSError):
            pass
        finally:
            self._syncs.pop(call, None)

    # -- the link --------------------------------------------------------------------

    async def _run(self) -> None:
        first = True
        while not self._closing:
            try:
                async with connect(
                    self.url, max_size=self.max_size, compression=None, open_timeout=5
                ) as ws:
                    self._ws = ws
                    if not first:
                        self.stats.reconnects += 1
                        await self._send_setup()
                        lost, self._lost = self._lost, 0
                        self._link(
                            f"upstream {redact(self.url)} reconnected"
                            + (f" ({lost} frames could not be sent while it was away)"
                               if lost else "")
                        )  # fmt: skip
                    first = False
                    self._connected.set()
                    async for message in ws:
                        self._on_message(message)
            except InvalidURI as exc:
                raise UpstreamError(f"invalid rosbridge URL {redact(self.url)}: {exc}") from None
            except (OSError, ConnectionClosed, InvalidHandshake, asyncio.TimeoutError):
                pass
            if self._ws is not None and not self._closing:
                self._link(f"upstream {redact(self.url)} lost: reconnecting")
            self._ws = None
            self._connected.clear()
            if not self._closing:
                await asyncio.sleep(self.reconnect_delay)

    def _link(self, text: str) -> None:
        self._pending.append(("link", text))
        self._wake.set()

    def _on_message(self, message: str | bytes) -> None:
        text = message if isinstance(message, str) else bytes(message).decode("utf-8", "replace")
        if '"status"' in text or _SYNC in text:
            try:
                frame = json.loads(text)
            except ValueError:
                frame = None
            if isinstance(frame, dict):
                msg_id = str(frame.get("id", ""))
                if msg_id.startswith(_SYNC):
                    done = self._syncs.get(msg_id)
                    if done is not None and not done.done():
                        done.set_result(None)
                    return
                if frame.get("op") == "status":
                    level = str(frame.get("level", "info"))
                    self.stats.statuses[level] = self.stats.statuses.get(level, 0) + 1
                    what = self._setup_ids.get(msg_id)
                    if what is not None and level == "error" and self._setting_up:
                        self._refusals.append(f"{what}: {frame.get('msg', '')}")
        self._pending.append(("frame", text))
        self._wake.set()

    # -- outputs ---------------------------------------------------------------------

    def flush(self) -> None:
        """Forward what the bridge produced for the external server since the last call."""
        for output in self.bridge.drain():
            self._forward(output)

    def _forward(self, output: OutgoingFrame) -> None:
        if output.connection != self.connection or output.op not in _FORWARD:
            return
        text = output.data if isinstance(output.data, str) else output.data.decode("utf-8")
        if output.op == "publish" and output.name in self._latched_topics:
            self._latched[output.name] = text
        if self._ws is None:
            self._send_failed(f"{output.op} {output.name}".strip(), "the link is down")
            return
        self._outgoing.put_nowait(text)

    def _send_failed(self, what: str, reason: str) -> None:
        """Count a frame that could not be sent; log it, and report the first of an outage
        as a transport status (recorded as a marker at the next step boundary)."""
        self.stats.send_failures += 1
        text = f"upstream {redact(self.url)}: could not send {what}: {reason}"
        self.stats.last_send_failure = text
        self._lost += 1
        if self._lost == 1:
            _log.warning("%s (frames are lost until the link is back)", text)
            if not self._closing:
                self._link(f"{text} (frames are lost until the link is back)")

    async def _send_loop(self) -> None:
        """Send in order; after every :data:`_WINDOW` frames wait for a round trip, so the
        server's queue of unprocessed frames stays bounded (rosbridge-server-rs closes a
        connection whose queue of 256 frames overflows, e.g. the burst of a long step call)."""
        unconfirmed = 0
        while True:
            text = await self._outgoing.get()
            try:
                ws = self._ws
                if ws is None:
                    self._send_failed(_what(text), "the link is down")
                else:
                    await ws.send(text)
                    unconfirmed += 1
                    if unconfirmed >= _WINDOW:
                        unconfirmed = 0
                        await self._round_trip()
            except (ConnectionClosed, OSError) as exc:
                self._send_failed(_what(text), f"{type(exc).__name__}: {exc}")
            finally:
                self._outgoing.task_done()


def _what(text: str) -> str:
    """``op name`` of a frame's text (for a report of a frame that could not be sent)."""
    try:
        frame = json.loads(text)
    except ValueError:
        return "a frame"
    if not isinstance(frame, dict):
        return "a frame"
    name = next((frame[k] for k in ("topic", "service", "action") if k in frame), "")
    return f"{frame.get('op', '')} {name}".strip()
