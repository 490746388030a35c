"""Run every benchmark in ``bench/`` (or those named) and print one table of ratios.

python bench/run.py [--quick] [--json PATH] [--readme [PATH]] [NAME ...]

Each ``bench_<name>.py`` runs in its own interpreter (a crash, a hang or leftover memory in
one cannot spoil the others; a module that fails becomes a failed row naming the error) with a
time limit. The table goes to stdout, the rows and the machine to JSON (default
``bench/results/latest.json``, or ``latest-quick.json`` with ``--quick``; untracked); no
tracked file changes. With ``--readme`` (``make bench-readme``), when every benchmark ran, the
table also replaces the README section between the ``bench-table`` markers. Every target is a
ratio against a limit measured in the same run, so the exit status (0 when every row met its
target, 1 otherwise) says whether the product is as good as it claims on this machine.
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from common import Row, format_markdown, format_table, machine  # noqa: E402

README_START = "<!-- bench-table:start -->"
README_END = "<!-- bench-table:end -->"
LIMIT_S = {False: 420.0, True: 150.0}
"""Wall-clock limit of one benchmark module (full, quick)."""


def _child(name: str, quick: bool, out: Path) -> int:
    """Run one module in this interpreter and write its rows to ``out``."""
    sys.path.insert(0, str(ROOT))
    rows = importlib.import_module(name).run(quick)
    bad = [r for r in rows if not isinstance(r, Row)]
    if bad:
        raise TypeError(f"{name}.run() returned {type(bad[0]).__name__}, not common.Row")
    out.write_text(json.dumps([r.as_dict() for r in rows]))
    return 0


def _error_row(name: str, text: str) -> Row:
    return Row(f"{name}: did not finish", 0.0, 0.0, "", "runs to the end", False, note=text)


def _run_module(name: str, quick: bool) -> tuple[list[Row], float]:
    """Run ``name`` in a fresh interpreter; its rows (or one failed row) and wall seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        cmd = [sys.executable, str(Path(__file__).resolve()), "--child", name, "--out", str(out)]
        if quick:
            cmd.append("--quick")
        start = time.perf_counter()
        try:
            proc = subprocess.run(cmd, cwd=ROOT, timeout=LIMIT_S[quick], check=False)
        except subprocess.TimeoutExpired:
            return [_error_row(name, f"timed out after {LIMIT_S[quick]:.0f} s")], LIMIT_S[quick]
        elapsed = time.perf_counter() - start
        if proc.returncode != 0 or not out.exists():
            return [_error_row(name, f"exit status {proc.returncode} (see its output)")], elapsed
        fields = {"name", "ours", "limit", "unit", "target", "passed", "higher_is_better", "note"}
        rows = [
            Row(**{k: v for k, v in d.items() if k in fields}) for d in json.loads(out.read_text())
        ]
        return rows, elapsed


def update_readme(path: Path, rows: list[Row], header: str) -> bool:
    """Replace the README section between the markers with the table; False when the
    markers are missing (the file is left alone)."""
    text = path.read_text()
    start, end = text.find(README_START), text.find(README_END)
    if start < 0 or end < start:
        return False
    body = f"{README_START}\n{header}\n\n{format_markdown(rows)}\n{README_END}"
    path.write_text(text[:start] + body + text[end + len(README_END) :])
    return True


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="benchmark module names (bench_<name>.py)")
    parser.add_argument("--quick", action="store_true", help="shorter runs (a few minutes)")
    parser.add_argument("--json", type=Path, default=None, help="where to write the rows")
    parser.add_argument(
        "--readme",
        type=Path,
        nargs="?",
        const=ROOT / "README.md",
        default=None,
        help="also rewrite the benchmark table of this README (default README.md)",
    )
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return _child(args.child, args.quick, args.out)

    modules = sorted(p.stem for p in HERE.glob("bench_*.py"))
    if args.names:
        unknown = sorted(set(args.names) - {m.removeprefix("bench_") for m in modules})
        if unknown:
            parser.error(f"no benchmark named {', '.join(unknown)}")
        modules = [m for m in modules if m.removeprefix("bench_") in args.names]
    rows: list[Row] = []
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    for name in modules:
        print(f"== {name} ...", file=sys.stderr, flush=True)
        module_rows, seconds[name] = _run_module(name, args.quick)
        print(f"== {name}: {seconds[name]:.0f} s", file=sys.stderr, flush=True)
        rows.extend(module_rows)
    total = time.perf_counter() - started
    host = machine()
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    kind = "quick" if args.quick else "full"
    print()
    print(format_table(rows))
    print(f"\nmachine: {host}")
    print(f"{kind} run, {total:.0f} s: " + ", ".join(f"{n} {s:.0f} s" for n, s in seconds.items()))
    json_path = args.json or HERE / "results" / f"latest{'-quick' if args.quick else ''}.json"
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(
        json.dumps(
            {
                "machine": host,
                "date": when,
                "kind": kind,
                "seconds": {"total": total, **seconds},
                "rows": [r.as_dict() for r in rows],
            },
            indent=2,
        )
        + "\n"
    )
    print(f"JSON: {json_path}")
    if args.readme is not None and args.names:
        print("README not updated: a partial run (benchmarks named)")
    elif args.readme is not None and args.readme.exists():
        header = f"Latest run: {kind}, {when}, {total / 60:.1f} min, on {host}."
        if update_readme(args.readme, rows, header):
            print(f"README table updated: {args.readme}")
        else:
            print(f"README not updated: no {README_START} ... {README_END} section")
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
