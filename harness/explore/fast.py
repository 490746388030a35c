"""The fast path of an example (see :class:`FastRunner`)."""

from __future__ import annotations

from harness.scenario import IterationRunner, session_iteration_runner

__all__ = ["FastRunner"]


def FastRunner() -> IterationRunner:
    """The product's iteration runner (the compiled-world reuse is not in yet)."""
    return session_iteration_runner()
