"""Sessions made inside hypothesis' ``@given``: one example's sessions at a time.

A test that draws values with ``@given`` and makes its sessions with
``harness_session_factory`` runs its body once per example. Each example's sessions belong to
that example: when the factory is called in a new example, the earlier example's sessions end
and their recordings, snapshots and generated worlds are removed (they are superseded). The
last example hypothesis runs is the one it reports: when the test fails, that is the shrunk,
minimal failing example, so the test's folder keeps exactly its recording under the test's usual
names, like any failed test's; the failure itself lands in hypothesis' example database as
usual. hypothesis is looked up in ``sys.modules`` only: the plugin imports nothing for it.
"""

from __future__ import annotations

import sys

__all__ = ["current_example"]


def current_example() -> object | None:
    """The hypothesis example being run (its build context), or None outside ``@given``."""
    control = sys.modules.get("hypothesis.control")
    if control is None or not control.currently_in_test_context():
        return None
    context: object = control.current_build_context()
    return context
