"""Load: 20 rosbridge clients publishing and subscribing at 1 kHz against a recording Session.

No crash, bounded memory, every drop counted (the clients' received + reported drops equal
what their neighbour sent), and the recording complete: every frame the server received and
every frame it routed to a client is in the recording. The long version is bench/bench_load.py.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.load.loadrun import load_run

RSS_GROWTH_LIMIT_MB = 200.0


@pytest.mark.timeout(120)
@pytest.mark.slow
def test_twenty_clients_at_1khz(tmp_path: Path, record_property: pytest.RecordProperty) -> None:
    result = load_run(tmp_path / "load.mcap", clients=20, rate=1000.0, seconds=1.0, timeout=90)
    c = result.clients
    figures = {
        "sent": c["sent"],
        "received": c["received"],
        "dropped": c["dropped"],
        "latency_p99_ms": round(c["latency_us"]["p99"] / 1e3, 1),
        "rss_start_mb": round(result.rss_start_mb, 1),
        "rss_peak_mb": round(result.rss_peak_mb, 1),
        "steps": result.steps,
    }
    for key, value in figures.items():
        record_property(key, value)
    print(f"load: {figures}")

    assert result.failure is None
    assert [e for pc in c["per_client"] for e in pc["errors"]] == []
    assert c["sent"] == 20 * 1000  # every client published its whole schedule
    assert c["out_of_order"] == 0
    assert c["accounted"], "some client neither received nor was told about a frame"
    assert c["received"] + c["dropped"] == c["sent"]
    assert result.recording_complete, result.recording_problems
    assert result.mismatches() == []
    assert sum(result.recorded_in.values()) == c["sent"]
    assert result.steps > 0  # the simulation kept running under load
    assert result.rss_peak_mb - result.rss_start_mb < RSS_GROWTH_LIMIT_MB
