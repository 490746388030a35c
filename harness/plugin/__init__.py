"""The rooms of the harness pytest plugin; :mod:`harness.pytest_plugin` is its entry point
(``pytest11``) and holds the options, marker, fixtures and hooks pytest calls.

- :mod:`harness.plugin.settings`: the command-line options, their ini twins, ``HarnessSettings``.
- :mod:`harness.plugin.markers`: ``@pytest.mark.harness``'s keys and values, control modes.
- :mod:`harness.plugin.scenario`: the marker's ``scenario=`` (the scenario's session under the
  marker's keys).
- :mod:`harness.plugin.run`: one test's sessions, recordings and teardown; ``SessionFactory``.
- :mod:`harness.plugin.goldens`: golden recordings (``Golden``, names, the update command).
- :mod:`harness.plugin.report`: the failure report's ``harness`` section, bridge errors.

Like the entry point, every module here imports only the standard library, pytest and
:mod:`harness.vocabulary` at import time; this package itself imports none of them.
"""

from __future__ import annotations

__all__: list[str] = []
