"""Bridge fairness: one greedy client must not slow the simulation for everyone (issue 31, 4).

A realtime session (demo arm, 2 ms step, recording on) in this process; in another process
(like robot software) an attacker subscribes to ``/joint_states``, ``/tf`` and ``/clock`` with
``fragment_size: 1`` (one frame per character: on the code before issue 31 this took the
session from 1.00x to about 0.1x real time), and an observer calls ``/harness/get_state``
every 20 ms. The same session and observer without the attacker, in the same run, is the
limit: the realtime pace reached (simulated seconds per wall second, read on the session's
thread), the observer's service-call latency, and the recording's bytes per step. The pace
under attack must reach 0.95 of the unattacked pace (which is 1.0x real time on an idle
machine); the recording must not grow more than 2x per step.

The send budget (:mod:`harness.rosbridge.limits`), where the fragment_size floor is not
enough: a client publishes 1 MB messages at 50 Hz and another subscribes to them with
``fragment_size: 1`` (a thousand 1 KiB fragments per message); the session process's CPU
seconds per simulated second (less sensitive to other load on a shared machine than the
pace) must stay within 2x of the publisher's alone.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from common import Row

from harness.session import Session

_CLIENTS = r"""
import asyncio, json, sys, time
from websockets.asyncio.client import connect

url, seconds, attack = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "1"
TOPICS = (("/joint_states", "sensor_msgs/msg/JointState"), ("/tf", "tf2_msgs/msg/TFMessage"),
          ("/clock", "rosgraph_msgs/msg/Clock"))

async def attacker(stop, seen):
    async with connect(url, max_size=None, compression=None) as ws:
        await ws.send(json.dumps({"op": "set_level", "level": "warning"}))
        for topic, type_ in TOPICS:
            await ws.send(json.dumps({"op": "subscribe", "topic": topic, "type": type_,
                                      "fragment_size": 1}))
        while not stop.is_set():
            try:
                frame = await asyncio.wait_for(ws.recv(), 0.1)
            except asyncio.TimeoutError:
                continue
            seen["frames"] += 1
            if '"op":"status"' in frame:
                seen["warnings"] += 1

async def main():
    stop, seen = asyncio.Event(), {"frames": 0, "warnings": 0}
    task = asyncio.create_task(attacker(stop, seen)) if attack else None
    latencies = []
    async with connect(url, max_size=None, compression=None) as ws:
        await asyncio.sleep(0.5)  # the attacker's subscriptions are in
        print("start", flush=True)
        end = time.perf_counter() + seconds
        n = 0
        while time.perf_counter() < end:
            n += 1
            start = time.perf_counter()
            await ws.send(json.dumps({"op": "call_service", "service": "/harness/get_state",
                                      "id": n}))
            while json.loads(await ws.recv()).get("id") != n:
                pass
            latencies.append(time.perf_counter() - start)
            await asyncio.sleep(0.02)
    print("end", flush=True)
    stop.set()
    if task is not None:
        await task
    latencies.sort()
    print(json.dumps({"p50": latencies[len(latencies) // 2],
                      "p99": latencies[int(len(latencies) * 0.99)], **seen}), flush=True)

asyncio.run(main())
"""


_BIG = r"""
import asyncio, json, sys
from websockets.asyncio.client import connect

url, seconds, attack = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "1"

async def attacker(stop):
    async with connect(url, max_size=None, compression=None) as ws:
        await ws.send(json.dumps({"op": "subscribe", "topic": "/big",
                                  "type": "std_msgs/msg/String", "fragment_size": 1}))
        while not stop.is_set():
            try:
                await asyncio.wait_for(ws.recv(), 0.1)
            except asyncio.TimeoutError:
                pass

async def publisher(stop):
    async with connect(url, max_size=None, compression=None) as ws:
        await ws.send(json.dumps({"op": "advertise", "topic": "/big",
                                  "type": "std_msgs/msg/String"}))
        frame = json.dumps({"op": "publish", "topic": "/big", "msg": {"data": "x" * 10**6}})
        while not stop.is_set():
            await ws.send(frame)
            await asyncio.sleep(0.02)

async def main():
    stop = asyncio.Event()
    tasks = [asyncio.create_task(publisher(stop))]
    if attack:
        tasks.append(asyncio.create_task(attacker(stop)))
    await asyncio.sleep(0.5)
    print("start", flush=True)
    await asyncio.sleep(seconds)
    print("end", flush=True)
    stop.set()
    for task in tasks:
        await task

asyncio.run(main())
"""


def _big_run(seconds: float, attack: bool) -> float:
    """CPU seconds of this process (the session's thread, the recorder's) per simulated
    second while a client publishes 1 MB messages at 50 Hz, with or without a client
    subscribed to them in 1 KiB fragments."""
    with (
        tempfile.TemporaryDirectory() as tmp,
        Session("demo", clock="realtime", record_to=Path(tmp) / "big.mcap") as session,
    ):

        def sim_s() -> float:
            return float(session.core.sim.sim_time_ns) / 1e9

        proc = subprocess.Popen(
            [sys.executable, "-c", _BIG, session.url, str(seconds), "1" if attack else "0"],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "start"
        cpu0, sim0 = time.process_time(), session.call(sim_s)
        assert proc.stdout.readline().strip() == "end"
        cpu1, sim1 = time.process_time(), session.call(sim_s)
        proc.wait(timeout=60)
    return (cpu1 - cpu0) / max(sim1 - sim0, 1e-9)


def _run(seconds: float, attack: bool) -> dict[str, Any]:
    """One realtime session with the clients; the pace over the observer's run (simulated
    seconds per wall second), the observer's latencies and the recording's bytes per step."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fairness.mcap"
        with Session("demo", clock="realtime", record_to=path) as session:

            def sim_s() -> float:
                return float(session.core.sim.sim_time_ns) / 1e9

            proc = subprocess.Popen(
                [sys.executable, "-c", _CLIENTS, session.url, str(seconds), "1" if attack else "0"],
                stdout=subprocess.PIPE,
                text=True,
            )
            assert proc.stdout is not None
            assert proc.stdout.readline().strip() == "start"
            wall0, sim0 = time.perf_counter(), session.call(sim_s)
            assert proc.stdout.readline().strip() == "end"
            wall1, sim1 = time.perf_counter(), session.call(sim_s)
            report: dict[str, Any] = json.loads(proc.stdout.readline())
            proc.wait(timeout=60)
            steps = session.call(lambda: session.core.sim.step_index)
        report["pace"] = (sim1 - sim0) / (wall1 - wall0)
        report["bytes_per_step"] = path.stat().st_size / max(steps, 1)
    return report


def run(quick: bool) -> list[Row]:
    seconds = 4.0 if quick else 10.0
    calm = _run(seconds, attack=False)
    attacked = _run(seconds, attack=True)
    print(f"  unattacked: {calm}")
    print(f"  attacked:   {attacked}")
    note = (
        f"attacker: fragment_size 1 on /joint_states, /tf, /clock, got "
        f"{attacked['frames']} frames and {attacked['warnings']} warnings in {seconds:.0f} s; "
        f"pace {attacked['pace']:.3f}x vs {calm['pace']:.3f}x real time unattacked"
    )
    big_calm = _big_run(seconds, attack=False)
    big_attacked = _big_run(seconds, attack=True)
    print(f"  1 MB at 50 Hz: {big_calm:.3f} CPU s per simulated s, {big_attacked:.3f} attacked")
    pace_ratio = attacked["pace"] / calm["pace"]
    growth = calm["bytes_per_step"] / attacked["bytes_per_step"]
    return [
        Row("fairness: realtime pace, a fragment_size-1 subscriber attacking",
            attacked["pace"], calm["pace"], "x real time",
            "ratio >= 0.95 (>= 0.95 of the unattacked pace)", pace_ratio >= 0.95, note=note),
        Row("fairness: another client's service call p99, under attack",
            attacked["p99"] * 1e3, calm["p99"] * 1e3, "ms", "(info)", True,
            higher_is_better=False,
            note=f"p50 {attacked['p50'] * 1e3:.2f} ms vs {calm['p50'] * 1e3:.2f} ms unattacked"),
        Row("fairness: recording bytes per step, under attack",
            attacked["bytes_per_step"], calm["bytes_per_step"], "B/step",
            "ratio >= 0.5 (at most 2x the unattacked recording)", growth >= 0.5,
            higher_is_better=False),
        Row("fairness: CPU per simulated second, 1 MB messages to a fragment_size-1 subscriber",
            big_attacked, big_calm, "s/s", "ratio >= 0.5 (at most 2x the publisher alone)",
            big_calm / big_attacked >= 0.5, higher_is_better=False,
            note="a client publishes 1 MB at 50 Hz; another subscribes in 1 KiB fragments "
            "(~50,000 frames/s asked; its send budget lets 5,000/s through)"),
    ]  # fmt: skip
