"""The marker's ``srdf=`` (issue 34, finding 7): a path relative to the test file, as
``robot=``; its ``<disable_collisions>`` pairs are ignored."""

from __future__ import annotations

import shutil
from pathlib import Path

DEMO_SRDF = Path(__file__).resolve().parents[1] / "data" / "models" / "demo_arm.srdf"


def test_the_marker_takes_srdf(pytester, run):
    shutil.copy(DEMO_SRDF, pytester.path / "arm.srdf")
    pytester.makepyfile(
        test_srdf="""
        import pytest

        @pytest.mark.harness(robot="demo", srdf="arm.srdf")
        def test_pairs(harness_session):
            ignored = harness_session.robot.self_collision.ignored
            assert {(p.link1, p.link2) for p in ignored if p.reason == "srdf"} == {
                ("link0", "link2"), ("link5", "link7")
            }
        """
    )
    run().assert_outcomes(passed=1)
