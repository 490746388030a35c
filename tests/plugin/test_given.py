"""``@given`` with ``harness_session_factory`` (issue 36, "In pytest"): each example's sessions
end when the next example makes one, the failure lands in hypothesis' example database, and the
failed test keeps one recording, its minimal failing example's, under the test's usual name."""

from __future__ import annotations

from pathlib import Path

from harness.recording import Recording

REACH = """
from hypothesis import HealthCheck, given, settings, strategies as st
from hypothesis.database import DirectoryBasedExampleDatabase

SEEN = []

# the factory is safe across examples: each example's sessions are its own
@settings(
    max_examples=25,
    deadline=None,
    database=DirectoryBasedExampleDatabase("examples-db"),
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(centi=st.integers(min_value=0, max_value=100))
def test_reach(harness_session_factory, centi):
    target = centi / 100
    session = harness_session_factory()
    SEEN.append(session)
    # an earlier example's sessions have ended by now: only this example's is open
    assert [s for s in SEEN if not s.closed] == [session]
    session.command("joint1", position=target)
    session.step(250)
    assert session.joint_positions()[0] < LIMIT, target

LIMIT = 0.3
"""


def _last_positions(recording: Path) -> list[float]:
    """The positions on the recording's last ``/joint_states`` message."""
    with Recording(recording) as rec:
        messages = list(rec.messages("/joint_states", decode=True))
    assert messages, recording
    return [float(p) for p in messages[-1].msg.position]


def test_given_keeps_the_minimal_example_and_fills_the_database(pytester, run):
    pytester.makepyfile(test_examples=REACH)
    result = run("--harness-keep-recordings=failed")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    folder = pytester.path / ".harness/recordings/test_examples/test_reach"
    kept = sorted(p.name for p in folder.glob("*.mcap"))
    assert kept == ["test_reach.mcap"], kept  # the minimal example's only
    assert f"recording: {folder / 'test_reach.mcap'}" in out
    # the failure is in hypothesis' database: the next run fails at once on it
    assert any(p.is_file() for p in (pytester.path / "examples-db").rglob("*"))
    # the kept recording is the minimal example's: joint1 went to hypothesis' shrunk target,
    # the smallest failing one (0.30 or 0.31: the first that reaches LIMIT), not an earlier
    # example's (hypothesis' first examples are spread over 0 to 1)
    assert "centi=30," in out or "centi=31," in out
    position = _last_positions(folder / "test_reach.mcap")[0]
    assert 0.295 <= position < 0.315, position


def test_given_that_passes_keeps_nothing(pytester, run):
    pytester.makepyfile(test_examples=REACH.replace("LIMIT = 0.3", "LIMIT = 2.0"))
    result = run("--harness-keep-recordings=failed")
    result.assert_outcomes(passed=1)
    assert not list((pytester.path / ".harness").rglob("*.mcap"))
