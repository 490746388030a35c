"""A rich progress bar for long replays, shown only on a terminal."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

from harness.replay.verify import Progress

__all__ = ["progress_bar"]


@contextmanager
def progress_bar(description: str, *, stream: TextIO | None = None) -> Iterator[Progress | None]:
    """Yield a ``(done, total)`` callback drawing a bar on ``stream`` (default stderr), or
    ``None`` when the stream is not a terminal (CI logs stay clean)."""
    out = sys.stderr if stream is None else stream
    if not out.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=Console(file=out),
        transient=True,
    ) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update
