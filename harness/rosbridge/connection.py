"""A client's WebSocket connection to :class:`~harness.rosbridge.BridgeServer`: who may open
one (:func:`is_loopback` decides whether the server warns that it is exposed;
:func:`presented_token` reads the token a client presents) and
:class:`MessageConnection`, which hands each message to the server as it is read."""

from __future__ import annotations

import ipaddress
import urllib.parse
from collections.abc import Callable
from typing import Any

from websockets.asyncio.server import ServerConnection
from websockets.frames import DATA_OPCODES, CloseCode, Frame, Opcode
from websockets.http11 import Request
from websockets.protocol import Event

__all__ = ["MessageConnection", "is_loopback", "presented_token"]


class MessageConnection(ServerConnection):
    """A ``websockets`` server connection that hands each complete data message to
    :attr:`on_message` from ``data_received``, instead of queueing it for ``recv()``
    (``serve(create_connection=...)``; everything else, handshake, pings, closing, size
    limits, is the library's). Messages that arrive before the server attaches wait in
    :attr:`early`. Fragmented messages are joined here (the library bounds their total size
    by ``max_size``); a text message that is not UTF-8 fails the connection with 1007, as
    ``recv()`` would."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.on_message: Callable[[str | bytes], None] | None = None
        self.after_read: Callable[[], None] | None = None
        self.early: list[str | bytes] = []
        self._parts = bytearray()
        self._text = False

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if self.after_read is not None:
            self.after_read()

    def eof_received(self) -> None:
        super().eof_received()
        if self.after_read is not None:
            self.after_read()

    def process_event(self, event: Event) -> None:
        if not isinstance(event, Frame) or event.opcode not in DATA_OPCODES:
            super().process_event(event)  # the handshake request, pings, pongs, close
            return
        if event.opcode is not Opcode.CONT:
            self._text = event.opcode is Opcode.TEXT
        if not event.fin:
            self._parts += event.data
            return
        data = bytes(event.data)
        if self._parts:
            data, self._parts = bytes(self._parts + data), bytearray()
        message: str | bytes = data
        if self._text:
            try:
                message = data.decode()
            except UnicodeDecodeError as exc:
                self.set_connection_exc(exc)
                self.protocol.fail(CloseCode.INVALID_DATA, f"{exc.reason} at position {exc.start}")
                self.send_data()
                return
        if self.on_message is None:
            self.early.append(message)
        else:
            self.on_message(message)


def is_loopback(host: str) -> bool:
    """Whether ``host`` names only this machine (``localhost``, 127.0.0.0/8, ``::1``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def presented_token(request: Request) -> str | None:
    """The token a client presents: ``?token=`` on the URL, else ``Authorization: Bearer``."""
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(request.path).query)
    if query.get("token"):
        return query["token"][0]
    auth = request.headers.get("Authorization", "")
    scheme, _, value = auth.partition(" ")
    return value.strip() if scheme.lower() == "bearer" else None
