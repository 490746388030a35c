"""The marker key ``resume``: ``@pytest.mark.harness(resume={"from": "run.mcap", "at": K})``
gives the test a session continuing the recording from step K (recorded as the test's own
recording, a child naming its parent); wrong values fail the test in one line."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from harness.recording import Recording
from harness.resume import META_STEP
from tests.plugin.conftest import PLUGIN_ARGS

from .conftest import ARM_FORK


@pytest.fixture
def run(pytester: pytest.Pytester) -> Callable[..., pytest.RunResult]:
    def go(*args: str) -> pytest.RunResult:
        return pytester.runpytest_inprocess(*PLUGIN_ARGS, "-p", "no:cacheprovider", *args)

    return go


def test_the_marker_resumes_a_recording(
    arm_parent: Path, pytester: pytest.Pytester, run: Callable[..., pytest.RunResult]
) -> None:
    shutil.copy(arm_parent, pytester.path / "parent.mcap")
    pytester.makepyfile(
        test_resumed=f"""
        import pytest

        @pytest.mark.harness(resume={{"from": "parent.mcap", "at": {ARM_FORK}}})
        def test_from_the_fork(harness_session):
            assert harness_session.step_index == {ARM_FORK}
            harness_session.step(10)
            assert harness_session.step_index == {ARM_FORK + 10}

        @pytest.mark.harness(resume={{"from": "parent.mcap", "at": {ARM_FORK}}}, clock="fast")
        def test_other_keys_do_not_apply(harness_session):
            pass

        @pytest.mark.harness(resume={{"from": "parent.mcap", "at": 99999}})
        def test_beyond(harness_session):
            pass
        """
    )
    result = run("--harness-keep-recordings=always", "--harness-record-dir=out")
    result.assert_outcomes(passed=1, errors=2)
    text = result.stdout.str()
    assert "resume= continues what the recording simulated: clock do(es) not apply" in text
    assert "step 99999 is beyond the recording" in text
    (child,) = (pytester.path / "out").rglob("test_from_the_fork.mcap")
    with Recording(child) as rec:
        assert rec.metadata[META_STEP] == str(ARM_FORK)
        assert rec.last_step == ARM_FORK + 10
