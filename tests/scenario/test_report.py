"""report.html: self-contained, with plots and a collision timeline, rendered in headless
Chromium. The data comes from real iterations of the stand-in MuJoCo runner."""

import dataclasses
import re
import struct
import subprocess
from pathlib import Path

import pytest

from harness.scenario import ClientOutcome, Scenario, iteration_specs, load_run_file, render_html
from tests.scenario.scenario_testlib import EXAMPLES
from tests.scenario.standins import StepLoadRunner

CHROMIUM = Path("/usr/bin/chromium")


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("report")
    (tmp / "s.yaml").write_text("robots: [{robot: demo}]\nduration: 4.0\n")
    config = load_run_file(tmp / "s.yaml")
    specs = iteration_specs(config, tmp / "out", iterations=2)
    runner = StepLoadRunner()
    first, second = (runner(s) for s in specs)
    first = dataclasses.replace(first, recording=specs[0].recording_path)
    second = dataclasses.replace(
        second,
        client=ClientOutcome("exited", 3, "client exited with code 3 <oops>", tmp / "client.log"),
    )
    errored = dataclasses.replace(second, iteration=3, error="runner raised ValueError: x")
    return [first, second, errored], tmp


def _joints(results):
    return sum(len(r.traces.joints) for r in results if r.traces is not None)


def test_report_is_self_contained_with_plots_timeline_verdicts_and_replay(results):
    rs, tmp = results
    page = render_html(rs, tmp / "s.yaml")
    # Nothing loaded from elsewhere: only the SVG namespace URI appears.
    assert re.findall(r"""(?:src|href)\s*=\s*["'](?!#)""", page) == []
    assert set(re.findall(r"https?://[^\s\"'<>]+", page)) == {"http://www.w3.org/2000/svg"}
    assert page.count('class="plot joint-position"') == _joints(rs)
    assert page.count('class="plot joint-velocity"') == _joints(rs)
    assert page.count('class="collision-timeline"') == 3
    assert page.count('<rect class="bar"') == sum(len(r.collisions) for r in rs)
    assert 'data-series="command"' in page
    assert '<line class="limit"' in page
    assert f"harness replay {rs[0].recording}" in page
    assert "client exited with code 3 &lt;oops&gt;" in page
    assert "runner raised ValueError: x" in page
    assert page.count('class="verdict"') == sum(len(r.verdicts) for r in rs)


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


@pytest.mark.skipif(
    not CHROMIUM.exists(), reason="needs Debian's chromium (/usr/bin/chromium; make system-deps)"
)
@pytest.mark.slow
def test_report_renders_in_headless_chromium(results, tmp_path):
    rs, tmp = results
    report = tmp_path / "report.html"
    report.write_text(render_html(rs, tmp / "s.yaml"))
    flags = [
        str(CHROMIUM),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}",
    ]
    dom = subprocess.run(
        [*flags, "--dump-dom", report.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout
    # The inline script ran (it counts the plots and marks the page ready) ...
    assert 'data-ready="1"' in dom
    plots = 2 * _joints(rs)
    assert f'<span id="plot-count">{plots} plots</span>' in dom
    # ... and the plots and timeline are in the rendered DOM.
    assert dom.count("<polyline") >= plots
    assert dom.count('class="collision-timeline"') == 3
    shot = tmp_path / "shot.png"
    subprocess.run(
        [*flags, f"--screenshot={shot}", "--window-size=1200,1600", report.as_uri()],
        capture_output=True,
        timeout=120,
        check=True,
    )
    assert _png_size(shot) == (1200, 1600)
    assert shot.stat().st_size > 20_000  # a blank page compresses to a few kB


def test_demo_scenario_report_title(results):
    rs, _ = results
    page = render_html(rs[:1], EXAMPLES / "demo.yaml")
    assert "<title>harness run: demo.yaml</title>" in page
    assert Scenario.load(EXAMPLES / "demo.yaml").name == "demo"
