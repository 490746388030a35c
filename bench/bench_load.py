"""Load: 20 rosbridge clients publishing and subscribing at 1 kHz against a recording Session.

The clients run in their own process (tests/load/loadgen.py); the session (demo arm, realtime
clock at its 2 ms step, recording on) in this one. The limit is the offered load (20 clients x
1 kHz = 20 000 frames/s in and as many out); ours is what the server delivered per second, until
the last frame arrived. Also: publish -> delivery latency, drops (every one counted: received +
reported drops must equal what was sent), the session process's RSS growth, the simulation's
step rate under load against real time, and whether the recording holds every frame.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from common import Row

from tests.load.loadrun import load_run

CLIENTS, RATE = 20, 1000.0


def run(quick: bool) -> list[Row]:
    seconds = 5.0 if quick else 30.0
    with tempfile.TemporaryDirectory() as tmp:
        r = load_run(
            Path(tmp) / "load.mcap", clients=CLIENTS, rate=RATE, seconds=seconds, timeout=600
        )
    c = r.clients
    offered = CLIENTS * RATE
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
            1.0,
            "ms",
            "report (limit: 1 period)",
            True,
            higher_is_better=False,
            note=f"p50 {c['latency_us']['p50'] / 1e3:.1f} ms",
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
            "report",
            True,
            note=f"realtime clock (2 ms step); {r.steps} steps in {r.session_seconds:.1f} s",
        ),
    ]
