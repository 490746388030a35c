"""``harness replay --actuation`` of an arm steps the session core, the engine of a live run
(issue 32): every re-simulated step is one :meth:`SessionCore.advance`."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.replay.resim import resimulate
from harness.session import SessionCore


@pytest.mark.parametrize("actuation", ["kinematic", "servo"])
def test_every_re_simulated_step_is_a_core_step(
    base_recording: Path, actuation: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    steps: list[int] = []
    advance = SessionCore.advance

    def counted(core: SessionCore) -> None:
        advance(core)
        steps.append(core.sim.step_index)

    monkeypatch.setattr(SessionCore, "advance", counted)
    report = resimulate(base_recording, actuation)
    assert report.steps == 300
    assert steps == list(range(1, 301))  # the core took each step, in order
