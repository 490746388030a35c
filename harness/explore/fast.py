"""The fast path of an example: what is kept warm between examples of one worker.

- the world: built once per topology, an example's values applied to it
  (:mod:`harness.explore.warm`);
- the shell: an example without a client program runs on a core directly
  (:mod:`harness.explore.kernel`), nothing recorded; the product's runner below runs the
  examples with a client program and the kept ones;
- the interpreter and its imports: a worker runs all its examples in one process;
- the bridge's message types: built once per process (``harness.rosbridge`` copies a built
  registry instead of generating a class per definition for every session);
- the stepping: a ``script`` span between two commands (or the whole run without one) is
  one request to the session instead of one per 10 steps (how steps are requested is not
  recorded: the recording is the one ``harness run`` makes, byte for byte; the explore
  tests check it for every failure found and 20 passing examples).
"""

from __future__ import annotations

import dataclasses
from typing import cast

from harness.scenario import IterationRunner, session_iteration_runner

__all__ = ["FAST_CHUNK", "FastRunner"]

FAST_CHUNK = 1_000_000
"""Steps per session request on the fast path (in effect: a whole span)."""


def FastRunner() -> IterationRunner:
    """The product's iteration runner with whole spans per step request (see the module
    docstring)."""
    runner: object = session_iteration_runner()
    return cast(IterationRunner, dataclasses.replace(runner, chunk=FAST_CHUNK))  # type: ignore[type-var]
