"""Run a runner config's iterations and write the reports: what ``harness run`` and
``harness demo`` do (each iteration's session from :mod:`harness.scenario.session_options`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from harness.errors import ConfigError
from harness.scenario.dask_backend import DaskBackend
from harness.scenario.interrupt import RunInterrupted
from harness.scenario.reports import print_summary, write_reports
from harness.scenario.results import IterationResult, IterationRunner
from harness.scenario.runfile import RunConfig
from harness.scenario.runner import Backend, iteration_specs, run_iterations

__all__ = ["run_scenarios"]


def run_scenarios(
    config: RunConfig,
    runner: IterationRunner,
    backend: Backend,
    out_dir: Path,
    console: Console,
    iterations: int | None = None,
    check_determinism: bool = False,
) -> list[IterationResult]:
    """Run every iteration of ``config`` with ``runner`` on ``backend`` (live progress on a
    terminal), write the reports into ``out_dir`` and print the summary table."""
    if iterations is not None and iterations < 1:
        raise ConfigError(f"--iterations: {iterations} must be at least 1")
    if check_determinism or any(p.scenario.criteria.deterministic for p in config.simulations):
        # Determinism is judged across iterations: every judged simulation runs at least 2.
        plans = []
        for plan in config.simulations:
            count = iterations if iterations is not None else plan.iterations
            if count < 2 and (check_determinism or plan.scenario.criteria.deterministic):
                console.print(
                    f"note: {plan.name}: running 2 iterations to check determinism", style="yellow"
                )
                count = 2
            plans.append(replace(plan, iterations=count))
        config = replace(config, simulations=tuple(plans))
        iterations = None
    specs = iteration_specs(config, out_dir, iterations)
    if console.is_terminal:
        with Progress(
            TextColumn("[bold]harness run"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[last]}"),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        ) as progress:
            task = progress.add_task("iterations", total=len(specs), last="")

            def advance(result: IterationResult) -> None:
                mark = "PASS" if result.passed else "FAIL"
                progress.update(
                    task, advance=1, last=f"{result.simulation} #{result.iteration} {mark}"
                )

            try:
                results = run_iterations(runner, specs, backend, check_determinism, advance)
            except RunInterrupted as exc:
                _write_partial(exc, out_dir, config, console)
                raise
    else:
        try:
            results = run_iterations(runner, specs, backend, check_determinism)
        except RunInterrupted as exc:
            _write_partial(exc, out_dir, config, console)
            raise
    paths = write_reports(results, out_dir, config.source)
    print_summary(results, console)
    if isinstance(backend, DaskBackend):  # what crossed the network, with sizes
        for line in backend.transfers.summary():
            console.print(line, highlight=False, markup=False, soft_wrap=True)
    for name, path in paths.items():
        console.print(f"{name}: {path}")
    return results


def _write_partial(exc: RunInterrupted, out_dir: Path, config: RunConfig, console: Console) -> None:
    """The reports of an interrupted run: the iterations that ran, nothing else."""
    paths = write_reports(exc.results, out_dir, config.source)
    print_summary(exc.results, console)
    for name, path in paths.items():
        console.print(f"{name}: {path}")
