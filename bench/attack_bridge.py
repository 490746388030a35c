"""Issue 31's bridge attacks against a running ``harness serve``, for before/after evidence.

python bench/attack_bridge.py fragments URL [SECONDS]
    Break 4: one client subscribes to /joint_states, /tf and /clock with ``fragment_size: 1``
    while another calls ``/harness/get_state`` every 50 ms; prints the real-time factor seen
    through those calls (simulated seconds per wall second) and the call latencies.
python bench/attack_bridge.py pending URL SERVER_PID [CALLS]
    Break 8: one client advertises a service it never answers, another calls it CALLS times
    (100,000 by default; in batches of 5,000, each followed by a call that is answered at
    once, so that no input queue builds up); prints the server's RSS before and after and
    what the caller got back.

Loopback only: give a ``ws://127.0.0.1:PORT`` URL.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time
from typing import Any

from websockets.asyncio.client import ClientConnection, connect

TOPICS = (
    ("/joint_states", "sensor_msgs/msg/JointState"),
    ("/tf", "tf2_msgs/msg/TFMessage"),
    ("/clock", "rosgraph_msgs/msg/Clock"),
)


async def _attacker(url: str, stop: asyncio.Event, seen: dict[str, Any]) -> None:
    async with connect(url, max_size=None, compression=None) as ws:
        await ws.send(json.dumps({"op": "set_level", "level": "warning"}))
        for topic, type_ in TOPICS:
            frame = {"op": "subscribe", "topic": topic, "type": type_, "fragment_size": 1}
            await ws.send(json.dumps(frame))
        while not stop.is_set():
            try:
                frame = await asyncio.wait_for(ws.recv(), 0.2)
            except TimeoutError:
                continue
            seen["frames"] += 1
            if '"op":"status"' in frame and len(seen["statuses"]) < 3:
                seen["statuses"].append(json.loads(frame)["msg"])


async def _get_state(ws: ClientConnection, n: int) -> tuple[float, float]:
    """Latency of one /harness/get_state call and the simulated time it answered."""
    start = time.perf_counter()
    await ws.send(json.dumps({"op": "call_service", "service": "/harness/get_state", "id": n}))
    while True:
        answer = json.loads(await ws.recv())
        if answer.get("op") == "service_response" and answer.get("id") == n:
            stamp = answer["values"]["sim_time"]
            return time.perf_counter() - start, stamp["sec"] + stamp["nanosec"] * 1e-9


async def fragments(url: str, seconds: float) -> dict[str, Any]:
    stop, seen = asyncio.Event(), {"frames": 0, "statuses": []}
    attacker = asyncio.create_task(_attacker(url, stop, seen))
    await asyncio.sleep(1.0)
    latencies = []
    async with connect(url, max_size=None, compression=None) as ws:
        _, sim0 = await _get_state(ws, 0)
        wall0 = time.perf_counter()
        n = 0
        while time.perf_counter() - wall0 < seconds:
            await asyncio.sleep(0.05)
            n += 1
            latency, sim1 = await _get_state(ws, n)
            latencies.append(latency)
        wall1 = time.perf_counter()
    stop.set()
    await attacker
    latencies.sort()
    return {
        "real_time_factor": (sim1 - sim0) / (wall1 - wall0),
        "call_p50_ms": latencies[len(latencies) // 2] * 1e3,
        "call_p99_ms": latencies[int(len(latencies) * 0.99)] * 1e3,
        "attacker_frames": seen["frames"],
        "attacker_statuses": seen["statuses"],
    }


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for pid {pid}")


async def pending(url: str, pid: int, calls: int) -> dict[str, Any]:
    async with (
        connect(url, max_size=None) as provider,
        connect(url, max_size=None) as caller,
    ):
        frame = {"op": "advertise_service", "service": "/never", "type": "std_srvs/srv/Trigger"}
        await provider.send(json.dumps(frame))
        await asyncio.sleep(0.5)
        before = _rss_mb(pid)
        reached = [0]

        async def drain() -> None:  # the provider reads its requests and never answers
            async for _ in provider:
                reached[0] += 1

        drainer = asyncio.create_task(drain())
        answers: list[dict[str, Any]] = []
        for batch in range(0, calls, 5000):
            for i in range(batch, min(calls, batch + 5000)):
                call = {"op": "call_service", "service": "/never", "id": i, "timeout": 3600}
                await caller.send(json.dumps(call))
            barrier = {"op": "call_service", "service": "/rosapi/topics", "id": "barrier"}
            await caller.send(json.dumps(barrier))
            while (answer := json.loads(await caller.recv())).get("id") != "barrier":
                answers.append(answer)
        await asyncio.sleep(1.0)
        after = _rss_mb(pid)
        drainer.cancel()
    return {
        "calls": calls,
        "rss_before_mb": round(before, 1),
        "rss_after_mb": round(after, 1),
        "held_per_call_bytes": round((after - before) * 2**20 / calls, 1),
        "answered_before_timeout": len(answers),
        "first_answer": answers[0] if answers else None,
        "requests_reaching_provider": reached[0],
    }


def main(argv: list[str]) -> None:
    if len(argv) >= 2 and argv[0] == "fragments":
        seconds = float(argv[2]) if len(argv) > 2 else 6.0
        print(json.dumps(asyncio.run(fragments(argv[1], seconds))))
    elif len(argv) >= 3 and argv[0] == "pending":
        calls = int(argv[3]) if len(argv) > 3 else 100_000
        print(json.dumps(asyncio.run(pending(argv[1], int(argv[2]), calls))))
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
