"""rosbridge relay on loopback: our server vs a raw ``websockets`` relay (the library's limit).

One publisher client and one subscriber client; the server runs in its own process.
Figures: small-message relay rate, publish -> own-subscription round trip p50/p99 at 1 kHz,
and a burst of 500 x 100 kB messages (all must arrive).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import multiprocessing as mp
import statistics
import time
from typing import Any

from common import Row
from websockets.asyncio.client import connect
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

TOPIC = "/bench"


def _serve_ours(conn: Any) -> None:
    from harness.rosbridge import BridgeServer

    async def main() -> None:
        async with BridgeServer(ping_interval=None) as server:
            conn.send(server.port)
            await asyncio.get_running_loop().run_in_executor(None, conn.recv)

    asyncio.run(main())


def _serve_raw(conn: Any) -> None:
    """A minimal relay: every frame from any client goes to every client that sent "sub"."""

    async def main() -> None:
        subscribers: set[ServerConnection] = set()

        async def handler(ws: ServerConnection) -> None:
            try:
                async for message in ws:
                    if message == "sub":
                        subscribers.add(ws)
                        await ws.send("ok")
                        continue
                    for sub in list(subscribers):
                        with contextlib.suppress(ConnectionClosed):
                            await sub.send(message)
            finally:
                subscribers.discard(ws)

        async with serve(
            handler, "127.0.0.1", 0, compression=None, max_size=2**24, ping_interval=None
        ) as server:
            conn.send(server.sockets[0].getsockname()[1])
            await asyncio.get_running_loop().run_in_executor(None, conn.recv)

    asyncio.run(main())


class Target:
    """How a client talks to one server kind."""

    def __init__(self, kind: str, port: int) -> None:
        self.kind = kind
        self.url = f"ws://127.0.0.1:{port}"

    async def subscribe(self, ws: Any) -> None:
        if self.kind == "raw":
            await ws.send("sub")
            assert await ws.recv() == "ok"
        else:
            await ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "topic": TOPIC,
                        "type": "std_msgs/String",
                        "queue_length": 10_000,
                    }
                )
            )
            await ws.send(
                json.dumps({"op": "call_service", "service": "/rosapi/topics", "id": "sync"})
            )
            await ws.recv()

    async def advertise(self, ws: Any) -> None:
        if self.kind == "ours":
            await ws.send(
                json.dumps({"op": "advertise", "topic": TOPIC, "type": "std_msgs/String"})
            )

    @staticmethod
    def frame(data: str) -> str:
        return json.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": data}})


async def relay_rate(t: Target, n: int) -> float:
    async with connect(t.url, compression=None) as sub, connect(t.url, compression=None) as pub:
        await t.subscribe(sub)
        await t.advertise(pub)
        frames = [t.frame(str(i)) for i in range(n)]
        start = time.perf_counter()

        async def produce() -> None:
            for f in frames:
                await pub.send(f)

        producer = asyncio.create_task(produce())
        for _ in range(n):
            await sub.recv()
        elapsed = time.perf_counter() - start
        await producer
        return n / elapsed


async def round_trip(t: Target, n: int) -> tuple[float, float]:
    async with connect(t.url, compression=None) as ws:
        await t.subscribe(ws)
        await t.advertise(ws)
        samples = []
        next_at = time.perf_counter()
        for i in range(n):
            next_at += 0.001
            start = time.perf_counter()
            await ws.send(t.frame(str(i)))
            await ws.recv()
            samples.append((time.perf_counter() - start) * 1000)
            delay = next_at - time.perf_counter()
            if delay > 0:
                await asyncio.sleep(delay)
        samples.sort()
        return statistics.median(samples), samples[int(len(samples) * 0.99) - 1]


async def burst(t: Target, n: int, size: int) -> tuple[int, float]:
    async with (
        connect(t.url, compression=None, max_size=2**24, ping_interval=None) as sub,
        connect(t.url, compression=None, max_size=2**24, ping_interval=None) as pub,
    ):
        await t.subscribe(sub)
        await t.advertise(pub)
        payload = "x" * size
        got = 0

        async def consume() -> None:
            nonlocal got
            try:
                while got < n:
                    await asyncio.wait_for(sub.recv(), 5)
                    got += 1
            except asyncio.TimeoutError:
                pass

        start = time.perf_counter()
        consumer = asyncio.create_task(consume())
        for i in range(n):
            await pub.send(t.frame(f"{i}:{payload}"))
        await consumer
        return got, n * size / (time.perf_counter() - start) / 1e6


def measure(kind: str, quick: bool) -> dict[str, float]:
    ctx = mp.get_context("spawn")
    parent, child = ctx.Pipe()
    proc = ctx.Process(target=_serve_ours if kind == "ours" else _serve_raw, args=(child,))
    proc.start()
    try:
        t = Target(kind, parent.recv())
        n = 5_000 if quick else 20_000
        rate = max(asyncio.run(relay_rate(t, n)) for _ in range(1 if quick else 3))
        p50, p99 = asyncio.run(round_trip(t, 500 if quick else 2_000))
        got, mbps = asyncio.run(burst(t, 500, 100_000))
        return {"rate": rate, "p50": p50, "p99": p99, "burst": got, "mbps": mbps}
    finally:
        parent.send("stop")
        proc.join(10)
        if proc.is_alive():
            proc.kill()


def run(quick: bool) -> list[Row]:
    ours, raw = measure("ours", quick), measure("raw", quick)
    return [
        Row(
            "bridge: small-message relay rate",
            ours["rate"],
            raw["rate"],
            "msg/s",
            ">=20000 and >=50% raw",
            ours["rate"] >= 20_000 and ours["rate"] >= 0.5 * raw["rate"],
            note="reference ~4,600 msg/s",
        ),
        Row(
            "bridge: round trip p50 at 1 kHz",
            ours["p50"],
            raw["p50"],
            "ms",
            "(info)",
            True,
            higher_is_better=False,
        ),
        Row(
            "bridge: round trip p99 at 1 kHz",
            ours["p99"],
            raw["p99"],
            "ms",
            "< 2 ms",
            ours["p99"] < 2.0,
            higher_is_better=False,
        ),
        Row(
            "bridge: burst 500 x 100 kB delivered",
            ours["burst"],
            raw["burst"],
            "msg",
            "500/500",
            ours["burst"] == 500,
            note="reference 239/500",
        ),
        Row(
            "bridge: burst 500 x 100 kB throughput",
            ours["mbps"],
            raw["mbps"],
            "MB/s",
            "(info)",
            True,
            note="reference ~6.9 MB/s",
        ),
    ]
