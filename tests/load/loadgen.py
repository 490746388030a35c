"""Load generator: N rosbridge clients publishing and subscribing at a fixed rate.

Run as a script (its own process, like robot software):
``python loadgen.py URL --clients 20 --rate 1000 --seconds 2`` prints one JSON object.

Client ``i`` advertises ``/load/c<i>`` and subscribes to ``/load/c<i+1 mod N>`` (and to
``/joint_states``); after a barrier (every subscription registered), each client publishes
``std_msgs/msg/String`` frames ``"<i>:<n>:<perf_counter_ns>"`` on a fixed schedule for the given
wall time (frames that fall behind the schedule are sent as soon as possible: the offered load
stays ``rate x seconds``). Then two rounds of ``/rosapi/topics`` calls flush every path: after
the second, each client has received every frame published to it except those the server
dropped, which the server reports in ``warning`` status frames (``dropped N messages on T``),
counted here. ``accounted`` says whether ``received + dropped == neighbour's sent`` held for
every client. Latencies are publish -> delivery on this process's clock.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import statistics
import sys
import time
from dataclasses import dataclass, field
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed

_DROPPED = re.compile(r"dropped (\d+) messages on (\S+?):")


@dataclass
class Client:
    index: int
    topic: str
    listens_to: str
    ws: ClientConnection | None = None
    sent: int = 0
    received: int = 0
    out_of_order: int = 0
    last_seen: int = -1
    last_ns: int = 0
    dropped: int = 0
    joint_states: int = 0
    errors: list[str] = field(default_factory=list)
    latencies_us: list[float] = field(default_factory=list)
    answers: dict[str, asyncio.Future[Any]] = field(default_factory=dict)

    async def read(self) -> None:
        assert self.ws is not None
        try:
            async for raw in self.ws:
                now = time.perf_counter_ns()
                frame = json.loads(raw)
                op = frame.get("op")
                if op == "publish":
                    topic = frame.get("topic")
                    if topic == self.listens_to:
                        self.received += 1
                        self.last_ns = now
                        _, n, sent_ns = frame["msg"]["data"].split(":")
                        if int(n) <= self.last_seen:
                            self.out_of_order += 1
                        self.last_seen = int(n)
                        if len(self.latencies_us) < 200_000:
                            self.latencies_us.append((now - int(sent_ns)) / 1e3)
                    elif topic == "/joint_states":
                        self.joint_states += 1
                elif op == "service_response":
                    future = self.answers.pop(str(frame.get("id")), None)
                    if future is not None and not future.done():
                        future.set_result(frame)
                elif op == "status":
                    text = str(frame.get("msg", ""))
                    match = _DROPPED.search(text)
                    if match and match.group(2) == self.listens_to:
                        self.dropped += int(match.group(1))
                    elif frame.get("level") == "error":
                        self.errors.append(text)
        except ConnectionClosed as exc:
            self.errors.append(f"connection closed: {exc}")

    async def call(self, call_id: str) -> None:
        assert self.ws is not None
        future: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self.answers[call_id] = future
        await self.ws.send(
            json.dumps({"op": "call_service", "service": "/rosapi/topics", "id": call_id})
        )
        await asyncio.wait_for(future, 30)


async def run(url: str, n: int, rate: float, seconds: float, joint_states: bool) -> dict[str, Any]:
    clients = [Client(i, f"/load/c{i}", f"/load/c{(i + 1) % n}") for i in range(n)]
    readers = []
    for c in clients:
        c.ws = await connect(url, compression=None, max_size=2**24, ping_interval=None)
        readers.append(asyncio.create_task(c.read()))
        await c.ws.send(
            json.dumps({"op": "advertise", "topic": c.topic, "type": "std_msgs/msg/String"})
        )
        await c.ws.send(
            json.dumps({"op": "subscribe", "topic": c.listens_to, "type": "std_msgs/msg/String"})
        )
        if joint_states:
            await c.ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "topic": "/joint_states",
                        "type": "sensor_msgs/msg/JointState",
                    }
                )
            )
    await asyncio.gather(*(c.call("ready") for c in clients))

    period_ns = int(1e9 / rate)
    total = int(rate * seconds)
    start = time.perf_counter_ns()
    behind_max = 0
    while True:
        now = time.perf_counter_ns()
        due = min(total, (now - start) // period_ns + 1)
        if all(c.sent >= total for c in clients):
            break
        for c in clients:
            assert c.ws is not None
            burst = min(due, c.sent + 50)
            while c.sent < burst:
                await c.ws.send(
                    json.dumps(
                        {
                            "op": "publish",
                            "topic": c.topic,
                            "msg": {"data": f"{c.index}:{c.sent}:{time.perf_counter_ns()}"},
                        }
                    )
                )
                c.sent += 1
            behind_max = max(behind_max, due - c.sent)
        next_ns = start + (min(c.sent for c in clients)) * period_ns
        delay = (next_ns - time.perf_counter_ns()) / 1e9
        await asyncio.sleep(max(delay, 0))
    publish_s = (time.perf_counter_ns() - start) / 1e9

    await asyncio.gather(*(c.call("flush1") for c in clients))
    await asyncio.gather(*(c.call("flush2") for c in clients))
    deadline = time.monotonic() + 10
    expected = {c.index: clients[(c.index + 1) % n].sent for c in clients}

    def settled() -> bool:
        return all(c.received + c.dropped >= expected[c.index] for c in clients)

    while not settled() and time.monotonic() < deadline:
        await asyncio.sleep(0.01)
    for c in clients:
        assert c.ws is not None
        await c.ws.close()
    await asyncio.gather(*readers, return_exceptions=True)

    latencies = sorted(x for c in clients for x in c.latencies_us)

    def pct(p: float) -> float:
        return latencies[min(len(latencies) - 1, int(len(latencies) * p))] if latencies else 0.0

    return {
        "clients": n,
        "rate_hz": rate,
        "seconds": seconds,
        "offered_per_client": total,
        "publish_seconds": publish_s,
        "delivery_seconds": (max(c.last_ns for c in clients) - start) / 1e9,
        "behind_max_frames": behind_max,
        "sent": sum(c.sent for c in clients),
        "received": sum(c.received for c in clients),
        "dropped": sum(c.dropped for c in clients),
        "joint_states": sum(c.joint_states for c in clients),
        "out_of_order": sum(c.out_of_order for c in clients),
        "accounted": all(c.received + c.dropped == expected[c.index] for c in clients),
        "latency_us": {
            "p50": statistics.median(latencies) if latencies else 0.0,
            "p99": pct(0.99),
            "max": latencies[-1] if latencies else 0.0,
        },
        "per_client": [
            {
                "topic": c.topic,
                "listens_to": c.listens_to,
                "sent": c.sent,
                "received": c.received,
                "dropped": c.dropped,
                "errors": c.errors[:5],
            }
            for c in clients
        ],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("url")
    parser.add_argument("--clients", type=int, default=20)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--no-joint-states", action="store_true")
    args = parser.parse_args()
    result = asyncio.run(
        run(args.url, args.clients, args.rate, args.seconds, not args.no_joint_states)
    )
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
