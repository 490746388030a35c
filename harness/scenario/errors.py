"""Errors of the scenario package."""

from __future__ import annotations

from collections.abc import Sequence

from harness.errors import ConfigError, HarnessError

__all__ = ["RunnerError", "ScenarioError"]


class ScenarioError(ConfigError):
    """A scenario or runner file is invalid; ``problems`` lists every problem found.

    The message is one line per problem, each naming the file, the key path and the value.
    """

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems: tuple[str, ...] = tuple(problems)
        super().__init__(
            "; ".join(self.problems)
            if len(self.problems) == 1
            else f"{len(self.problems)} problems:\n  " + "\n  ".join(self.problems)
        )


class RunnerError(HarnessError):
    """The runner machinery failed (a worker died, a backend could not be reached)."""
