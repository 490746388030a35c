"""The plugin tests' set-up (pytester itself is enabled in the top-level conftest.py, the only
place pytest allows ``pytest_plugins``), and the arguments that load the plugin in inner runs."""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import entry_points

import pytest

# Imported here, before any inner run: pytester restores sys.modules after each in-process run,
# and the simulation stack must not be re-imported every time.
import harness.events
import harness.pytest_plugin
import harness.recording
import harness.replay
import harness.session
import harness.testing  # noqa: F401


def _installed() -> bool:
    return any(ep.value == "harness.pytest_plugin" for ep in entry_points(group="pytest11"))


PLUGIN_ARGS: tuple[str, ...] = () if _installed() else ("-p", "harness.pytest_plugin")
"""Empty once the ``pytest11`` entry point is installed; ``-p harness.pytest_plugin`` before."""


@pytest.fixture
def plugin_args() -> tuple[str, ...]:
    return PLUGIN_ARGS


@pytest.fixture
def run(pytester: pytest.Pytester) -> Callable[..., pytest.RunResult]:
    """``run(*args)``: pytest in-process in the pytester folder, with the plugin loaded."""

    def go(*args: str) -> pytest.RunResult:
        return pytester.runpytest_inprocess(*PLUGIN_ARGS, "-p", "no:cacheprovider", *args)

    return go
