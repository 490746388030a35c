"""How the ``harness`` command shows Python warnings: ``harness: warning: <message>``, one
line, no source line, each distinct message once per run.

A model's load notes (a repaired inertia, a lifted base) are warnings for the Python API,
where ``warnings`` filters apply; on a terminal the file and line of the harness code that
raised them (``robot = RobotBuild(index, request, cache_dir)``) say nothing to the user, and a
command that loads the same robot twice (a replay re-simulation rebuilds it from a fresh
temporary copy) would say the same thing twice. Messages that differ only in the folders of
the paths they name are the same message.
"""

from __future__ import annotations

import contextlib
import re
import sys
import warnings
from collections.abc import Iterator
from typing import TextIO

__all__ = ["one_line_warnings"]

_FOLDERS = re.compile(r"(?:[^\s:'\"()]*/)+")


def _key(category: type[Warning], text: str) -> tuple[str, str]:
    """What makes two warnings the same: category and text with paths' folders dropped."""
    return category.__name__, _FOLDERS.sub("", text)


@contextlib.contextmanager
def one_line_warnings(prog: str = "harness", stream: TextIO | None = None) -> Iterator[None]:
    """Within the block, every warning that the filters let through is written to ``stream``
    (default: ``sys.stderr`` at the time of writing) as ``<prog>: warning: <message>`` on one
    line, each distinct message once. The filters themselves are left as they are."""
    seen: set[tuple[str, str]] = set()

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        text = " ".join(str(message).split())
        key = _key(category, text)
        if key in seen:
            return
        seen.add(key)
        out = file or stream or sys.stderr
        with contextlib.suppress(OSError, ValueError):  # a closed stream says nothing
            out.write(f"{prog}: warning: {text}\n")
            out.flush()

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield
