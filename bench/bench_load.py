"""Load: 20 rosbridge clients publishing and subscribing at 1 kHz against a recording Session.

The clients run in their own process (tests/load/loadgen.py); the session (demo arm, realtime
clock at its 2 ms step, recording on) in this one. The limit is the offered load (20 clients x
1 kHz = 20 000 frames/s in and as many out); ours is what the server delivered per second, until
the last frame arrived. Also: publish -> delivery latency, drops (every one counted: received +
reported drops must equal what was sent), the session process's RSS growth, the simulation's
step rate under load against real time, and whether the recording holds every frame. The
latency's floor: the same generator against a bare ``websockets`` relay in this process.

A second, shorter run (same load) measures CPU instead of wall time, which the other
engineers' jobs on a shared machine disturb far less: the session thread's CPU per relayed
frame against one core's budget at the offered rate, and the cores the load needs (session
plus load generator) against the machine's. A third, profiled, says where the session
thread's time goes, by area (printed).
"""

from __future__ import annotations

import cProfile
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from areas import format_areas
from common import Row, websockets_thread

from harness.session import Session
from tests.load.loadrun import LOADGEN, load_run

CLIENTS, RATE = 20, 1000.0


def _cpu_run(seconds: float, profile: cProfile.Profile | None) -> dict[str, Any]:
    """The load against a recording realtime session; CPU seconds of the session's thread
    (where all of its work happens) and of the load generator, and the generator's report."""
    with (
        tempfile.TemporaryDirectory() as tmp,
        Session("demo", clock="realtime", record_to=Path(tmp) / "cpu.mcap") as session,
    ):
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        if profile is not None:
            session.call(profile.enable)
        start = session.call(time.thread_time)
        out = subprocess.run(
            [sys.executable, str(LOADGEN), session.url, "--clients", str(CLIENTS),
             "--rate", str(RATE), "--seconds", str(seconds)],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
        session_cpu = session.call(time.thread_time) - start
        if profile is not None:
            session.call(profile.disable)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    report = json.loads(out)
    return {
        "session_cpu": session_cpu,
        "loadgen_cpu": after.ru_utime + after.ru_stime - children.ru_utime - children.ru_stime,
        "frames": report["sent"] + report["received"],
        "relayed": report["received"],
        "report": report,
    }


def _cpu_rows(cpu: dict[str, Any], offered: float) -> list[Row]:
    """The CPU figures of a :func:`_cpu_run` as rows."""
    relayed = max(cpu["relayed"], 1)
    per_frame = cpu["session_cpu"] / relayed * 1e6
    budget = 1e6 / offered
    session_cores = per_frame * offered / 1e6
    loadgen_cores = cpu["loadgen_cpu"] / relayed * offered
    need = session_cores + loadgen_cores
    cores = float(os.cpu_count() or 1)
    print(
        f"  CPU run: session {cpu['session_cpu']:.2f} s, load generator "
        f"{cpu['loadgen_cpu']:.2f} s for {cpu['relayed']} frames relayed; latency p99 "
        f"{cpu['report']['latency_us']['p99'] / 1e3:.1f} ms"
    )
    return [
        Row(
            "load: session thread CPU per relayed frame vs one core at 20 kHz",
            per_frame,
            budget,
            "us",
            "(info: ratio >= 1: one core serves the load)",
            True,
            higher_is_better=False,
            note=f"{cpu['session_cpu']:.2f} s CPU for {cpu['relayed']} frames relayed "
            "(parse, apply, record in and out, encode, send)",
        ),
        Row(
            "load: CPU the load needs (session + load generator), of the cores",
            need,
            cores,
            "cores",
            "(info: ratio >= 1: the machine can run it)",
            True,
            higher_is_better=False,
            note=f"session {session_cores:.2f} + load generator {loadgen_cores:.2f} cores "
            f"at the offered {offered:g} frames/s; other jobs on the machine not counted",
        ),
    ]


def _raw_relay_latency(seconds: float) -> dict[str, Any]:
    """The floor of the latency rows: the same load generator against a bare ``websockets``
    relay (the library the session serves with) on a thread of this process, as the session
    runs: each frame parsed, a ``publish`` sent on to its topic's subscribers as rosbridge
    frames it, a ``call_service`` answered; no simulation, validation or recording (and no
    ``/joint_states``: the generator is told not to subscribe). The generator's report."""
    from websockets.asyncio.server import ServerConnection

    subscribers: dict[str, set[ServerConnection]] = {}

    async def handler(ws: ServerConnection) -> None:
        async for raw in ws:
            frame = json.loads(raw)
            op = frame.get("op")
            if op == "subscribe":
                subscribers.setdefault(frame["topic"], set()).add(ws)
            elif op == "publish":
                text = json.dumps(
                    {"op": "publish", "topic": frame["topic"], "msg": frame["msg"]},
                    separators=(",", ":"),
                )
                for sub in tuple(subscribers.get(frame["topic"], ())):
                    await sub.send(text)
            elif op == "call_service":
                answer = {
                    "op": "service_response",
                    "service": frame["service"],
                    "id": frame.get("id"),
                    "values": {"topics": []},
                    "result": True,
                }
                await ws.send(json.dumps(answer))

    with websockets_thread(handler) as (port, _):
        out = subprocess.run(
            [sys.executable, str(LOADGEN), f"ws://127.0.0.1:{port}", "--clients",
             str(CLIENTS), "--rate", str(RATE), "--seconds", str(seconds),
             "--no-joint-states"],
            capture_output=True, text=True, check=True,
        ).stdout  # fmt: skip
    report: dict[str, Any] = json.loads(out)
    return report


def run(quick: bool) -> list[Row]:
    seconds = 5.0 if quick else 30.0
    offered = CLIENTS * RATE
    failed = ""
    try:  # first, so that its RSS figures start from a fresh process
        with tempfile.TemporaryDirectory() as tmp:
            r = load_run(
                Path(tmp) / "load.mcap", clients=CLIENTS, rate=RATE, seconds=seconds, timeout=600
            )
    except RuntimeError as exc:  # the load generator gave up (a backlog past its timeouts)
        failed = str(exc).strip().splitlines()[-1][:200]
        print(f"  load run failed: {exc}")
    raw = _raw_relay_latency(min(seconds, 10.0))
    cpu = _cpu_run(min(seconds, 5.0), None)
    profile = cProfile.Profile()
    profiled = _cpu_run(2.0, profile)
    cpu_rows = _cpu_rows(cpu, offered)
    print("where the session thread's time goes under load (profiled run, own time by area):")
    print(format_areas(profile, max(profiled["relayed"], 1), "frame"))
    if failed:
        return [
            Row("load: the 20 x 1 kHz run ends", 0.0, 1.0, "", "runs to the end", False,
                note=f"load generator: {failed}"),
            *cpu_rows,
        ]  # fmt: skip
    c = r.clients
    delivered = c["received"] / c["delivery_seconds"] if c["delivery_seconds"] else 0.0
    wall = c["delivery_seconds"]
    realtime_steps = 500.0  # the demo's 2 ms step
    mismatches = r.mismatches()
    complete = r.recording_complete and not mismatches and r.failure is None
    print(
        f"  load: {c['sent']} sent, {c['received']} received, {c['dropped']} dropped, "
        f"accounted {c['accounted']}; RSS {r.rss_start_mb:.0f} -> peak {r.rss_peak_mb:.0f} MiB; "
        f"{r.steps} steps; recording complete {complete} {mismatches[:3]}"
    )
    note = f"{CLIENTS} clients x {RATE:g} Hz for {seconds:g} s"
    return [
        Row(
            "load: relayed frames/s, 20 clients x 1 kHz, recording",
            delivered,
            offered,
            "msg/s",
            "report",
            True,
            note=f"{note}; {c['sent']} sent, last delivered after {wall:.1f} s",
        ),
        Row(
            "load: publish -> delivery latency p99",
            c["latency_us"]["p99"] / 1e3,
            10.0,
            "ms",
            "p99 <= 10 ms",
            c["latency_us"]["p99"] <= 10_000,
            higher_is_better=False,
            note=f"p50 {c['latency_us']['p50'] / 1e3:.1f} ms",
        ),
        Row(
            "load: latency p99, ours vs a raw websockets relay under the same load",
            c["latency_us"]["p99"] / 1e3,
            raw["latency_us"]["p99"] / 1e3,
            "ms",
            "(info: the floor on this machine)",
            True,
            higher_is_better=False,
            note=f"raw relay: p50 {raw['latency_us']['p50'] / 1e3:.1f} ms, "
            f"{min(seconds, 10.0):g} s, no simulation, validation or recording",
        ),
        Row(
            "load: frames received or reported dropped, of sent",
            c["received"] + c["dropped"],
            c["sent"],
            "msg",
            "all (drops counted)",
            bool(c["accounted"]) and c["received"] + c["dropped"] == c["sent"],
            note=f"{c['dropped']} dropped (each reported to its client), "
            f"{c['out_of_order']} out of order",
        ),
        Row(
            "load: recording holds every frame in and out",
            sum(r.recorded_in.values()) + sum(r.recorded_out.values()),
            c["sent"] + c["received"] + c["dropped"],
            "msg",
            "all, file complete",
            complete,
        ),
        Row(
            "load: session RSS growth",
            r.rss_peak_mb - r.rss_start_mb,
            r.rss_start_mb,
            "MiB",
            "ratio >= 1 (growth <= the session's RSS at start)",
            r.rss_peak_mb - r.rss_start_mb <= r.rss_start_mb,
            higher_is_better=False,
            note=f"start {r.rss_start_mb:.0f} MiB, peak {r.rss_peak_mb:.0f} MiB",
        ),
        Row(
            "load: sim steps/s under load vs real time",
            r.steps / r.session_seconds,
            realtime_steps,
            "st/s",
            "ratio >= 0.95",
            r.steps / r.session_seconds >= 0.95 * realtime_steps,
            note=f"realtime clock (2 ms step); {r.steps} steps in {r.session_seconds:.1f} s",
        ),
        *cpu_rows,
    ]
