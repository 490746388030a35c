"""Results of a run: ``junit.xml``, ``results.json``, a self-contained ``report.html`` and the
terminal summary table.

The HTML report has no external resources (inline SVG plots, inline CSS and a few lines of
inline JavaScript), so it opens offline: per iteration the verdicts, the replay command,
position and velocity plots per joint against commands and limits, and a collision timeline.
"""

from __future__ import annotations

import dataclasses
import html
import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from harness._version import __version__
from harness.scenario.results import CollisionSummary, IterationResult, JointTrace, Traces
from harness.scenario.sensor_report import camera_frames_html, laser_scans_html

__all__ = [
    "render_html",
    "summary_table",
    "write_html",
    "write_json",
    "write_junit",
    "write_reports",
]

_MAX_POINTS = 1500


def write_reports(
    results: Sequence[IterationResult], out_dir: Path, source: Path
) -> dict[str, Path]:
    """Write junit.xml, results.json and report.html into ``out_dir``; returns their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {
        "junit": out_dir / "junit.xml",
        "json": out_dir / "results.json",
        "html": out_dir / "report.html",
    }
    write_junit(results, paths["junit"])
    write_json(results, paths["json"], source)
    write_html(results, paths["html"], source)
    return paths


# --- JUnit ------------------------------------------------------------------------------------


def write_junit(results: Sequence[IterationResult], path: Path) -> None:
    """JUnit XML: one testsuite per simulation, one testcase per iteration; verdict failures
    are ``<failure>``, iterations that could not run are ``<error>``."""
    root = ET.Element("testsuites", name="harness run")
    suites: dict[str, ET.Element] = {}
    totals = {"tests": 0, "failures": 0, "errors": 0, "time": 0.0}
    for r in results:
        suite = suites.get(r.simulation)
        if suite is None:
            suite = ET.SubElement(root, "testsuite", name=r.simulation)
            suite.attrib.update(tests="0", failures="0", errors="0", skipped="0", time="0")
            suites[r.simulation] = suite
        case = ET.SubElement(
            suite,
            "testcase",
            classname=f"harness.{r.simulation}",
            name=f"iteration {r.iteration}",
            time=f"{r.wall_seconds:.3f}",
        )
        kind = None
        if r.error is not None:
            kind = "errors"
            ET.SubElement(case, "error", message=r.error, type="IterationError").text = r.error
        elif not r.passed:
            kind = "failures"
            failed = [v for v in r.verdicts if not v.passed]
            element = ET.SubElement(
                case, "failure", message=r.reason or "", type=",".join(v.name for v in failed)
            )
            element.text = "\n".join(f"{v.name}: {v.detail}" for v in failed)
        lines = [f"{'PASS' if v.passed else 'FAIL'} {v.name}: {v.detail}" for v in r.verdicts]
        lines.append(f"sim time reached: {r.sim_time:.6g} s ({r.steps} steps)")
        if r.replay_command:
            lines.append(f"replay: {r.replay_command}")
        if r.client is not None and r.client.log_path is not None:
            lines.append(f"client log: {r.client.log_path}")
        ET.SubElement(case, "system-out").text = "\n".join(lines)
        counts = {"tests": 1, "failures": int(kind == "failures"), "errors": int(kind == "errors")}
        for key, value in counts.items():
            suite.set(key, str(int(suite.get(key, "0")) + value))
            totals[key] += value
        suite.set("time", f"{float(suite.get('time', '0')) + r.wall_seconds:.3f}")
        totals["time"] += r.wall_seconds
    root.attrib.update(
        tests=str(totals["tests"]),
        failures=str(totals["failures"]),
        errors=str(totals["errors"]),
        time=f"{totals['time']:.3f}",
    )
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)


# --- JSON -------------------------------------------------------------------------------------


def _result_dict(r: IterationResult) -> dict[str, Any]:
    data = dataclasses.asdict(r)
    data.update(passed=r.passed, reason=r.reason, replay_command=r.replay_command)
    return data


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def write_json(results: Sequence[IterationResult], path: Path, source: Path) -> None:
    """``results.json``: every result (traces included), a summary, and run metadata."""
    document = {
        "harness_version": __version__,
        "source": str(source),
        "written_at": datetime.now(timezone.utc).isoformat(),
        "summary": {
            "iterations": len(results),
            "passed": sum(r.passed for r in results),
            "failed": sum(not r.passed for r in results),
        },
        "results": [_jsonable(_result_dict(r)) for r in results],
    }
    path.write_text(json.dumps(document, indent=1, default=str, allow_nan=False), encoding="utf-8")


# --- terminal ---------------------------------------------------------------------------------


def summary_table(results: Sequence[IterationResult]) -> Table:
    """A rich table: one row per iteration with its result and reason or replay command."""
    table = Table(title="harness run", show_lines=False)
    for column in ("simulation", "iter", "result", "sim time", "wall", "details"):
        table.add_column(column, overflow="fold")
    for r in results:
        details = r.reason if not r.passed else (r.replay_command or "")
        table.add_row(
            r.simulation,
            str(r.iteration),
            "[green]PASS[/green]" if r.passed else "[red]FAIL[/red]",
            f"{r.sim_time:.3f} s",
            f"{r.wall_seconds:.2f} s",
            details or "",
        )
    return table


def print_summary(results: Sequence[IterationResult], console: Console) -> None:
    """Print the summary table and a one-line total."""
    console.print(summary_table(results))
    shown: dict[str, tuple[str, ...]] = {}
    for r in results:
        shown.setdefault(r.simulation, r.settings)
    for simulation, settings in shown.items():
        if settings:
            console.print(f"verdict settings of {simulation}:", highlight=False)
            for line in settings:
                console.print(f"  {line}", highlight=False, markup=False, soft_wrap=True)
    passed = sum(r.passed for r in results)
    console.print(f"{passed}/{len(results)} iterations passed")


# --- HTML -------------------------------------------------------------------------------------

_CSS = """
body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;background:#fafafa}
h1{font-size:1.4em} h2{font-size:1.15em;margin-top:1.6em} h3{font-size:1em}
section.iteration{background:#fff;border:1px solid #ddd;border-radius:6px;
  padding:0.8em 1.2em;margin:1em 0}
section.iteration.fail{border-left:6px solid #c62828}
section.iteration.pass{border-left:6px solid #2e7d32}
table{border-collapse:collapse} td,th{border:1px solid #ddd;padding:0.25em 0.6em;text-align:left}
.PASS{color:#2e7d32;font-weight:bold} .FAIL{color:#c62828;font-weight:bold}
code{background:#eee;padding:0.1em 0.3em;border-radius:3px}
.plots{display:flex;flex-wrap:wrap;gap:0.5em}
svg{background:#fff;border:1px solid #eee}
svg text{font-size:11px;fill:#333}
.axis{stroke:#888;stroke-width:1} .grid{stroke:#eee;stroke-width:1}
.s-position,.s-velocity{fill:none;stroke:#1565c0;stroke-width:1.5}
.s-command{fill:none;stroke:#ef6c00;stroke-width:1.2;stroke-dasharray:5 3}
.limit{stroke:#c62828;stroke-width:1;stroke-dasharray:2 2}
.bar{fill:#c62828;opacity:0.75}
svg text.s-position-legend,svg text.s-velocity-legend{fill:#1565c0}
svg text.s-command-legend{fill:#ef6c00}
"""

_JS = """
(function(){
  var box=document.getElementById('failed-only');
  function apply(){
    document.querySelectorAll('section.iteration.pass').forEach(function(s){
      s.style.display = box.checked ? 'none' : '';});
  }
  box.addEventListener('change', apply); apply();
  var plots=document.querySelectorAll('svg.plot').length;
  document.getElementById('plot-count').textContent = plots + ' plots';
  document.body.setAttribute('data-ready','1');
})();
"""

_W, _H = 560, 200
_PAD_L, _PAD_R, _PAD_T, _PAD_B = 58, 12, 24, 30


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def _decimate(time: Sequence[float], values: Sequence[float]) -> list[tuple[float, float]]:
    stride = max(1, math.ceil(len(time) / _MAX_POINTS))
    return [(time[i], values[i]) for i in range(0, len(time), stride)]


def _ticks(lo: float, hi: float, n: int = 5) -> list[float]:
    if hi <= lo:
        return [lo]
    return [lo + (hi - lo) * i / (n - 1) for i in range(n)]


def _line_plot(
    css: str,
    title: str,
    unit: str,
    time: Sequence[float],
    series: Sequence[tuple[str, Sequence[float], str]],
    limits: Sequence[tuple[str, float]],
) -> str:
    """An SVG line plot: ``series`` (label, values, css class) against ``time``, horizontal
    dashed lines at ``limits``."""
    finite = [v for _, values, _ in series for v in values if math.isfinite(v)]
    finite += [y for _, y in limits]
    t0, t1 = (time[0], time[-1]) if time else (0.0, 1.0)
    if t1 <= t0:
        t1 = t0 + 1.0
    y0, y1 = (min(finite), max(finite)) if finite else (-1.0, 1.0)
    margin = (y1 - y0) * 0.08 or 1.0
    y0, y1 = y0 - margin, y1 + margin
    pw, ph = _W - _PAD_L - _PAD_R, _H - _PAD_T - _PAD_B

    def px(t: float) -> float:
        return _PAD_L + (t - t0) / (t1 - t0) * pw

    def py(v: float) -> float:
        return _PAD_T + (1.0 - (v - y0) / (y1 - y0)) * ph

    parts = [
        f'<svg class="plot {css}" xmlns="http://www.w3.org/2000/svg" width="{_W}" height="{_H}" '
        f'viewBox="0 0 {_W} {_H}" role="img" aria-label="{html.escape(title)}">',
        f'<text x="4" y="15" font-weight="bold">{html.escape(f"{title} [{unit}]")}</text>',
    ]
    for y in _ticks(y0, y1):
        parts.append(
            f'<line class="grid" x1="{_PAD_L}" x2="{_W - _PAD_R}" '
            f'y1="{py(y):.1f}" y2="{py(y):.1f}"/>'
            f'<text x="{_PAD_L - 4}" y="{py(y) + 4:.1f}" text-anchor="end">{_fmt(y)}</text>'
        )
    for t in _ticks(t0, t1):
        parts.append(
            f'<text x="{px(t):.1f}" y="{_H - _PAD_B + 14}" text-anchor="middle">{_fmt(t)}</text>'
        )
    parts.append(
        f'<text x="{_W - _PAD_R}" y="{_H - 3}" text-anchor="end">sim time [s]</text>'
        f'<line class="axis" x1="{_PAD_L}" x2="{_PAD_L}" y1="{_PAD_T}" y2="{_H - _PAD_B}"/>'
        f'<line class="axis" x1="{_PAD_L}" x2="{_W - _PAD_R}" '
        f'y1="{_H - _PAD_B}" y2="{_H - _PAD_B}"/>'
    )
    for label, y in limits:
        parts.append(
            f'<line class="limit" x1="{_PAD_L}" x2="{_W - _PAD_R}" '
            f'y1="{py(y):.1f}" y2="{py(y):.1f}">'
            f"<title>{html.escape(label)} {_fmt(y)}</title></line>"
        )
    legend_x = _PAD_L + 250
    for label, values, cls in series:
        segment: list[str] = []
        segments: list[list[str]] = [segment]
        for t, v in _decimate(time, values):
            if math.isfinite(v):
                segment.append(f"{px(t):.1f},{py(v):.1f}")
            elif segment:
                segment = []
                segments.append(segment)
        for seg in segments:
            if seg:
                parts.append(
                    f'<polyline class="{cls}" data-series="{html.escape(label)}" '
                    f'points="{" ".join(seg)}"/>'
                )
        parts.append(
            f'<text class="legend {cls}-legend" x="{legend_x}" y="15">{html.escape(label)}</text>'
        )
        legend_x += 70
    if limits:
        parts.append(f'<text class="legend" x="{legend_x}" y="15" fill="#c62828">limits</text>')
    parts.append("</svg>")
    return "".join(parts)


def _joint_plots(traces: Traces) -> str:
    out = []
    for jt in traces.joints:
        out.append(_joint_block(traces.time, jt))
    return "".join(out)


def _joint_block(time: Sequence[float], jt: JointTrace) -> str:
    pos_series: list[tuple[str, Sequence[float], str]] = [("position", jt.position, "s-position")]
    if jt.command is not None:
        pos_series.append(("command", jt.command, "s-command"))
    pos_limits = [
        (name, v) for name, v in (("lower", jt.lower), ("upper", jt.upper)) if v is not None
    ]
    vel_limits = []
    if jt.velocity_limit is not None:
        vel_limits = [("-limit", -jt.velocity_limit), ("+limit", jt.velocity_limit)]
    return (
        f'<div class="plots joint" data-joint="{html.escape(jt.joint)}">'
        + _line_plot(
            "joint-position", f"{jt.joint}: position", "rad | m", time, pos_series, pos_limits
        )
        + _line_plot(
            "joint-velocity",
            f"{jt.joint}: velocity",
            "rad/s | m/s",
            time,
            [("velocity", jt.velocity, "s-velocity")],
            vel_limits,
        )
        + "</div>"
    )


def _timeline(collisions: Sequence[CollisionSummary], sim_time: float) -> str:
    pairs = sorted({(c.body1, c.body2) for c in collisions})
    row_h = 20
    height = _PAD_T + max(1, len(pairs)) * row_h + _PAD_B
    width = 760
    left = 220
    pw = width - left - _PAD_R
    t1 = sim_time if sim_time > 0 else 1.0

    def px(t: float) -> float:
        return left + min(max(t / t1, 0.0), 1.0) * pw

    parts = [
        f'<svg class="collision-timeline" xmlns="http://www.w3.org/2000/svg" width="{width}" '
        f'height="{height}" viewBox="0 0 {width} {height}" role="img" '
        'aria-label="collision timeline">',
        '<text x="4" y="15" font-weight="bold">collisions (begin to end, sim time)</text>',
    ]
    if not pairs:
        parts.append(f'<text x="{left}" y="{_PAD_T + 14}">no collisions</text>')
    for row, pair in enumerate(pairs):
        y = _PAD_T + row * row_h
        parts.append(
            f'<text x="{left - 6}" y="{y + 14}" text-anchor="end">'
            f"{html.escape(' - '.join(pair))}</text>"
        )
        for c in collisions:
            if (c.body1, c.body2) != pair:
                continue
            end = c.end if c.end is not None else sim_time
            x0, x1 = px(c.begin), px(end)
            tip = (
                f"{c.body1} - {c.body2}: {c.begin:.4g} s to "
                f"{'end of run' if c.end is None else f'{c.end:.4g} s'}, "
                f"peak depth {c.peak_depth:.3g} m, peak force {c.peak_force:.3g} N"
            )
            parts.append(
                f'<rect class="bar" x="{x0:.1f}" y="{y + 3}" width="{max(x1 - x0, 1.5):.1f}" '
                f'height="{row_h - 6}"><title>{html.escape(tip)}</title></rect>'
            )
    axis_y = height - _PAD_B
    parts.append(
        f'<line class="axis" x1="{left}" x2="{width - _PAD_R}" y1="{axis_y}" y2="{axis_y}"/>'
    )
    for t in _ticks(0.0, t1):
        parts.append(
            f'<text x="{px(t):.1f}" y="{axis_y + 14}" text-anchor="middle">{_fmt(t)}</text>'
        )
    parts.append("</svg>")
    return "".join(parts)


def _iteration_section(r: IterationResult) -> str:
    status = "pass" if r.passed else "fail"
    rows = "".join(
        f'<tr class="verdict"><td>{html.escape(v.name)}</td>'
        f'<td class="{"PASS" if v.passed else "FAIL"}">{"PASS" if v.passed else "FAIL"}</td>'
        f"<td>{html.escape(v.detail)}</td></tr>"
        for v in r.verdicts
    )
    error = f'<p class="error FAIL">{html.escape(r.error)}</p>' if r.error else ""
    replay = (
        f'<p>Replay: <code class="replay">{html.escape(r.replay_command)}</code></p>'
        if r.replay_command
        else "<p>No recording.</p>"
    )
    client = ""
    if r.client is not None:
        log = (
            f" (log: <code>{html.escape(str(r.client.log_path))}</code>)"
            if r.client.log_path
            else ""
        )
        client = f"<p>Client: {html.escape(r.client.reason)}{log}</p>"
    notes = "".join(f'<p class="note">Note: {html.escape(n)}</p>' for n in r.notes)
    if r.settings:
        items = "".join(f"<li>{html.escape(s)}</li>" for s in r.settings)
        notes += (
            '<details class="settings"><summary>Verdict settings</summary>'
            f"<ul>{items}</ul></details>"
        )
    plots = (
        _joint_plots(r.traces)
        if r.traces is not None and r.traces.time
        else "<p>No joint traces.</p>"
    )
    anchor = html.escape(f"{r.simulation}-{r.iteration}")
    return (
        f'<section class="iteration {status}" id="{anchor}">'
        f"<h2>{html.escape(r.simulation)} — iteration {r.iteration}: "
        f'<span class="{status.upper()}">{status.upper()}</span></h2>'
        f"<p>Sim time reached {r.sim_time:.6g} s ({r.steps} steps); "
        f"wall {r.wall_seconds:.2f} s.</p>"
        f'{error}<table class="verdicts"><tr><th>criterion</th><th>result</th><th>detail</th></tr>'
        f"{rows}</table>{replay}{client}{notes}"
        f"<h3>Collisions</h3>{_timeline(r.collisions, r.sim_time)}"
        f"<h3>Joints</h3>{plots}{camera_frames_html(r.recording)}"
        f"{laser_scans_html(r.recording)}</section>"
    )


def render_html(results: Sequence[IterationResult], source: Path) -> str:
    """The self-contained report page."""
    passed = sum(r.passed for r in results)
    overview = "".join(
        f'<tr><td><a href="#{html.escape(f"{r.simulation}-{r.iteration}")}">'
        f"{html.escape(r.simulation)}</a></td><td>{r.iteration}</td>"
        f'<td class="{"PASS" if r.passed else "FAIL"}">{"PASS" if r.passed else "FAIL"}</td>'
        f"<td>{html.escape(r.reason or '')}</td></tr>"
        for r in results
    )
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f"<title>harness run: {html.escape(source.name)}</title><style>{_CSS}</style></head><body>"
        f"<h1>harness run: {html.escape(str(source))}</h1>"
        f'<p class="summary">{passed} of {len(results)} iterations passed '
        f'(<span id="plot-count"></span>; harness {__version__}).</p>'
        '<p><label><input type="checkbox" id="failed-only"> failed iterations only</label></p>'
        f'<table class="overview"><tr><th>simulation</th><th>iteration</th><th>result</th>'
        f"<th>reason</th></tr>{overview}</table>"
        + "".join(_iteration_section(r) for r in results)
        + f"<script>{_JS}</script></body></html>"
    )


def write_html(results: Sequence[IterationResult], path: Path, source: Path) -> None:
    """Write :func:`render_html` to ``path``."""
    path.write_text(render_html(results, source), encoding="utf-8")
