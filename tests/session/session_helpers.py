"""A small synchronous rosbridge client for the session tests (websockets' sync client:
waits on frames, never sleeps)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from websockets.sync.client import ClientConnection, connect

TIMEOUT = 10.0


class Client:
    """A raw rosbridge v2 client: sends frames, records every frame it receives."""

    def __init__(self, url: str) -> None:
        # entered by hand: the connection lives across calls, close() exits it
        self.ws: ClientConnection = connect(url, compression=None).__enter__()
        self.received: list[dict[str, Any]] = []
        self.sent = 0
        self._ids = 0

    def send(self, frame: dict[str, Any] | str) -> None:
        self.ws.send(frame if isinstance(frame, str) else json.dumps(frame))
        self.sent += 1

    def recv(self) -> dict[str, Any]:
        frame: dict[str, Any] = json.loads(self.ws.recv(timeout=TIMEOUT))
        self.received.append(frame)
        return frame

    def recv_until(self, match: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
        """Receive until a frame matches; returns it (earlier frames stay in ``received``)."""
        while True:
            frame = self.recv()
            if match(frame):
                return frame

    def subscribe(self, topic: str, type: str) -> None:
        self.send({"op": "subscribe", "topic": topic, "type": type})

    def publish(self, topic: str, msg: dict[str, Any]) -> None:
        self.send({"op": "publish", "topic": topic, "msg": msg})

    def call(self, service: str, args: dict[str, Any] | None = None) -> dict[str, Any]:
        """Call a service and wait for its response frame."""
        self._ids += 1
        call_id = f"call:{self._ids}"
        self.send({"op": "call_service", "service": service, "args": args or {}, "id": call_id})
        return self.recv_until(
            lambda f: f.get("op") == "service_response" and f.get("id") == call_id
        )

    def step(self, steps: int) -> dict[str, Any]:
        answer = self.call("/harness/step", {"steps": steps})
        assert answer["result"] is True, answer
        return answer

    def messages(self, topic: str) -> list[dict[str, Any]]:
        """The ``msg`` of every publish frame received on ``topic``."""
        return [f["msg"] for f in self.received if f.get("op") == "publish" and f["topic"] == topic]

    def close(self) -> None:
        self.ws.close()
