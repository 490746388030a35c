"""An unstable simulation (MuJoCo's BADQACC) ends the Session's run cleanly: the error is
reported (naming the step and the warning), the session closes without raising, and the
recording is closed and valid, holding every state up to the failure and a /rosout error."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.errors import HarnessError
from harness.recording import Recording
from harness.session import Session

STABLE_STEPS = 50


def _blow_up(session: Session) -> None:
    """A force no light body survives, on the demo scene's free box (next step: BADQACC)."""
    session.call(lambda: session.sim.apply_wrench("box", force=(0.0, 0.0, 1e300)))


def _check_recording(path: Path, failed_at: int) -> None:
    with Recording(path, strict=True) as rec:
        assert rec.complete
        steps = [s.step for s in rec.physics_states()]
        assert steps[0] == 0
        assert steps[-1] >= STABLE_STEPS
        assert steps[-1] < failed_at  # the state that failed is not passed off as valid
        assert steps == list(range(steps[-1] + 1))  # every state up to the failure
        logs = [rec.decode(m) for m in rec.messages(["/rosout"])]
        errors = [log for log in logs if log.level >= 40]  # ERROR (40) or FATAL (50)
        assert errors, [log.msg for log in logs]
        assert any("BADQACC" in log.msg for log in errors)


@pytest.mark.timeout(60)
def test_badqacc_in_lockstep_ends_the_run_cleanly(tmp_path: Path) -> None:
    path = tmp_path / "unstable.mcap"
    session = Session("demo", record_to=path)
    try:
        session.step(STABLE_STEPS)
        _blow_up(session)
        with pytest.raises(HarnessError, match="BADQACC") as info:
            session.step(100)
        assert "step" in str(info.value)
        assert session.failure is not None
        assert "BADQACC" in str(session.failure)
        with pytest.raises(HarnessError):
            session.step(1)  # the run is over until a reset
    finally:
        session.close()  # closes cleanly: no exception from a failed run
    _check_recording(path, STABLE_STEPS + 1)


@pytest.mark.timeout(60)
def test_badqacc_under_a_free_running_clock(tmp_path: Path) -> None:
    path = tmp_path / "unstable_fast.mcap"
    with Session("demo", clock="fast", record_to=path) as session:
        session.run_until(lambda: session.sim.step_index >= STABLE_STEPS, sim_timeout=10)
        _blow_up(session)
        with pytest.raises(HarnessError, match="BADQACC"):
            session.run_until(lambda: False, sim_timeout=10)
        failure = session.failure
        assert failure is not None
        assert "BADQACC" in str(failure)
        failed_at = session.sim.step_index + 1
    _check_recording(path, failed_at)
