"""``harness_scenario``: the marker's ``scenario=`` run as ``harness run`` runs it (its client
program or script, its criteria), and the ``test_minimal.py`` that ``harness explore`` writes
with it: it fails while the scenario's bug is there (its recording kept, the failed verdict in
the report) and passes once the scenario is fixed.

Inner pytest runs in the pytester folder; real Sessions, real client processes, real MCAP."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from harness.explore import regression_test

REACH = Path(__file__).resolve().parents[1] / "explore" / "data" / "reach.yaml"


def _minimal(folder: Path, mode: str) -> Path:
    """reach.yaml as ``harness explore`` writes a minimal case: concrete values, no explore
    section; TARGET_X 0.3 with MODE fast is the planted bug (the arm hits the floor)."""
    doc = yaml.safe_load(REACH.read_text())
    doc.pop("explore")
    doc["client"]["env"] = {"TARGET_X": "0.3", "MODE": mode}
    doc["client"]["command"] = f"python {REACH.parent / 'clients' / 'reach.py'} 1.0"
    path = folder / "minimal.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_generated_regression_fails_while_the_bug_is_there(pytester, run):
    _minimal(pytester.path, "fast")
    pytester.makepyfile(test_minimal=regression_test("reach.yaml", "collision left_finger - world"))
    result = run("-q")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert "scenario:  collisions:" in out
    folder = pytester.path / ".harness" / "recordings" / "test_minimal" / "test_minimal_case"
    recording = folder / "test_minimal_case.mcap"
    assert recording.is_file()  # kept: the test failed
    assert f"harness replay {recording}" in out
    # the scenario fixed: the same test passes and its recording goes
    _minimal(pytester.path, "slow")
    result = run("-q")
    result.assert_outcomes(passed=1)
    assert not recording.exists()


def test_a_scripted_scenario_runs_through_the_marker(pytester, run):
    doc = yaml.safe_load(REACH.read_text())
    for key in ("explore", "client"):
        doc.pop(key)
    doc["duration"] = 0.2
    doc["script"] = [{"at": 0.0, "positions": {"joint2": 0.2}}]
    (pytester.path / "scripted.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    pytester.makepyfile(
        """
        import pytest

        @pytest.mark.harness(scenario="scripted.yaml")
        def test_scripted(harness_scenario):
            assert harness_scenario.passed, harness_scenario.reason
            assert harness_scenario.client is None
            assert harness_scenario.steps == 100
            assert [v.name for v in harness_scenario.verdicts]
        """
    )
    run("-q").assert_outcomes(passed=1)


@pytest.mark.parametrize(
    ("marker", "message"),
    [
        ("", "harness_scenario needs @pytest.mark.harness(scenario=FILE)"),
        ('scenario="minimal.yaml", mode="kinematic"', "harness option(s) mode do not apply"),
        ('scenario="absent.yaml"', "absent.yaml not found"),
    ],
)
def test_a_wrong_marker_fails_in_one_line(pytester, run, marker, message):
    _minimal(pytester.path, "slow")
    pytester.makepyfile(
        f"""
        import pytest

        @pytest.mark.harness({marker})
        def test_it(harness_scenario):
            pass
        """
    )
    result = run("-q")
    result.assert_outcomes(errors=1)
    assert message in result.stdout.str()
    assert "Traceback" not in result.stdout.str()
