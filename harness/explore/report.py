"""The search's report: a terminal table and ``report.html`` (a self-contained page with an
inline SVG plot of the two chosen parameter components: every example a dot, failing ones
red, the shrink path joined, the minimal case ringed)."""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from harness.explore.episode import Example
from harness.explore.outputs import MinimalCase
from harness.explore.parameters import Parameter
from harness.explore.search import SearchResult

__all__ = ["print_report", "render_html", "write_html"]


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    return str(value)


def print_report(result: SearchResult, minimal: MinimalCase | None, console: Console) -> None:
    """The terminal summary: what was tried, what failed, the minimal case."""
    examples = result.examples
    failed = sum(1 for e in examples if not e.passed)
    rate = len(examples) / result.wall_seconds if result.wall_seconds else 0.0
    console.print(
        f"harness explore: {len(examples)} examples ({result.generated} generated, "
        f"{len(examples) - result.generated} while shrinking) in {result.wall_seconds:.1f} s "
        f"({rate:.1f}/s), {failed} failing, {len(result.failures)} distinct failure(s)",
        highlight=False,
    )
    if result.failures:
        table = Table(title="failures (by signature)")
        for column in ("signature", "first found", "minimal", "shrink steps", "note"):
            table.add_column(column)
        for sig, t in result.failures.items():
            table.add_row(
                sig,
                _values(t.first.values),
                _values((t.minimal or t.first).values),
                str(len(t.path)),
                t.note or ("deterministic" if t.deterministic else ""),
            )
        console.print(table)
    primary = result.primary()
    if primary is not None:
        table = Table(title=f"minimal case: {primary.signature}")
        for column in ("parameter", "as written", "minimal"):
            table.add_column(column)
        nominal = result.plan.nominal()
        for p in result.plan.parameters:
            table.add_row(
                p.path,
                _fmt(nominal[p.path]),
                _fmt((primary.minimal or primary.first).values[p.path]),
            )
        console.print(table)
    if minimal is not None:
        console.print(
            f"minimal.yaml: {minimal.scenario}\nminimal.mcap: {minimal.recording} "
            f"(two cold runs {'byte-identical' if minimal.identical else 'DIFFER'}; "
            f"replay {minimal.replay_detail})\ntest_minimal.py: {minimal.test}",
            highlight=False,
        )


def _margins(e: Example) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in e.margins.items() if math.isfinite(v))


def _values(values: Any) -> str:
    return ", ".join(f"{k}={_fmt(v)}" for k, v in values.items())


def _component(parameters: tuple[Parameter, ...], label: str) -> tuple[Parameter, int]:
    for p in parameters:
        for i, name in enumerate(p.labels()):
            if name == label:
                return p, i
    raise KeyError(label)


def _point(
    e: Example, px: tuple[Parameter, int], py: tuple[Parameter, int]
) -> tuple[float, float] | None:
    x = px[0].components(e.values[px[0].path])[px[1]]
    y = py[0].components(e.values[py[0].path])[py[1]]
    if x is None or y is None:
        return None
    return x, y


def _bounds(p: Parameter, i: int, points: list[float]) -> tuple[float, float]:
    if p.kind in ("range", "integers"):
        lo, hi = p.low[i], p.high[i]
    else:
        lo, hi = min(points, default=0.0), max(points, default=1.0)
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi


def plot_svg(result: SearchResult, size: int = 420) -> str:
    """The two-parameter plot (empty string when the plan has fewer than two components)."""
    plan = result.plan
    if plan.plot is None:
        return ""
    px, py = (_component(plan.parameters, label) for label in plan.plot)
    examples = [(e, _point(e, px, py)) for e in result.examples]
    drawn = [(e, p) for e, p in examples if p is not None]
    xlo, xhi = _bounds(*px, [p[0] for _, p in drawn])
    ylo, yhi = _bounds(*py, [p[1] for _, p in drawn])
    pad = 40

    def sx(x: float) -> float:
        return pad + (x - xlo) / (xhi - xlo) * (size - 2 * pad)

    def sy(y: float) -> float:
        return size - pad - (y - ylo) / (yhi - ylo) * (size - 2 * pad)

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" '
        f'viewBox="0 0 {size} {size}" role="img">',
        f'<rect x="{pad}" y="{pad}" width="{size - 2 * pad}" height="{size - 2 * pad}" '
        'fill="#fafafa" stroke="#999"/>',
        f'<text x="{size / 2}" y="{size - 8}" text-anchor="middle" font-size="12">'
        f"{html.escape(plan.plot[0])}</text>",
        f'<text x="12" y="{size / 2}" text-anchor="middle" font-size="12" '
        f'transform="rotate(-90 12 {size / 2})">{html.escape(plan.plot[1])}</text>',
        f'<text x="{pad}" y="{size - pad + 14}" font-size="10">{xlo:.3g}</text>',
        f'<text x="{size - pad}" y="{size - pad + 14}" font-size="10" text-anchor="end">'
        f"{xhi:.3g}</text>",
        f'<text x="{pad - 4}" y="{size - pad}" font-size="10" text-anchor="end">{ylo:.3g}</text>',
        f'<text x="{pad - 4}" y="{pad + 8}" font-size="10" text-anchor="end">{yhi:.3g}</text>',
    ]
    for e, (x, y) in drawn:
        colour = "#2a9d2a" if e.passed else "#d62828"
        tip = html.escape(f"#{e.worker}.{e.index} {e.phase} {e.signature or 'pass'}")
        parts.append(
            f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="3" fill="{colour}" '
            f'fill-opacity="0.6"><title>{tip}</title></circle>'
        )
    primary = result.primary()
    if primary is not None:
        path = [_point(e, px, py) for e in primary.path]
        line = " ".join(f"{sx(p[0]):.1f},{sy(p[1]):.1f}" for p in path if p is not None)
        if line:
            parts.append(
                f'<polyline points="{line}" fill="none" stroke="#333" stroke-dasharray="3 2"/>'
            )
        end = _point(primary.minimal or primary.first, px, py)
        if end is not None:
            parts.append(
                f'<circle cx="{sx(end[0]):.1f}" cy="{sy(end[1]):.1f}" r="7" fill="none" '
                'stroke="#000" stroke-width="2"><title>minimal case</title></circle>'
            )
    parts.append("</svg>")
    return "\n".join(parts)


def render_html(result: SearchResult, minimal: MinimalCase | None) -> str:
    """``report.html``'s text."""
    examples = result.examples
    rows = "\n".join(
        f"<tr class='{'pass' if e.passed else 'fail'}'><td>{e.worker}.{e.index}</td>"
        f"<td>{e.phase}</td><td>{html.escape(_values(e.values))}</td>"
        f"<td>{'pass' if e.passed else html.escape(e.signature)}</td>"
        f"<td>{html.escape(_margins(e))}</td></tr>"
        for e in examples[:2000]
    )
    failures = "\n".join(
        f"<tr><td>{html.escape(sig)}</td><td>{html.escape(_values(t.first.values))}</td>"
        f"<td>{html.escape(_values((t.minimal or t.first).values))}</td><td>{len(t.path)}</td>"
        f"<td>{html.escape(t.note)}</td></tr>"
        for sig, t in result.failures.items()
    )
    minimal_html = ""
    if minimal is not None:
        minimal_html = (
            f"<p>minimal.yaml fails under <code>harness run</code>: {minimal.fails} "
            f"({html.escape(minimal.reason)}); two cold runs byte-identical: {minimal.identical}; "
            f"replay: {html.escape(minimal.replay_detail)}</p>"
        )
    return f"""<!doctype html>
<html><head><meta charset="utf-8">
<title>harness explore: {html.escape(result.plan.source.name)}</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:12px}}tr.fail td{{background:#fde}}</style>
</head><body>
<h1>harness explore: {html.escape(str(result.plan.source))}</h1>
<p>{len(examples)} examples ({result.generated} generated) in {result.wall_seconds:.1f} s;
{sum(1 for e in examples if not e.passed)} failing; {len(result.failures)} distinct failure(s).</p>
{minimal_html}
<h2>Parameter space</h2>
{plot_svg(result)}
<h2>Failures</h2>
<table><tr><th>signature</th><th>first found</th><th>minimal</th><th>shrink steps</th>
<th>note</th></tr>
{failures}</table>
<h2>Examples</h2>
<table><tr><th>#</th><th>phase</th><th>values</th><th>verdict</th><th>margins</th></tr>
{rows}</table>
</body></html>
"""


def write_html(result: SearchResult, minimal: MinimalCase | None, out: Path) -> Path:
    """Write ``report.html`` into ``out``."""
    path = out / "report.html"
    path.write_text(render_html(result, minimal), encoding="utf-8")
    return path
