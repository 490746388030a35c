"""The bundled scenarios against their goldens in recordings/scenarios (issue 15): a behaviour
change fails here with the first divergent step. Intended changes: ``make goldens``."""

from pathlib import Path

import pytest
import yaml

from harness.recording import Recording
from harness.recording.layout import ATTACHMENT_MODEL_BINARY
from harness.scenario import goldens


@pytest.mark.parametrize("name", goldens.BUNDLED)
@pytest.mark.slow
def test_bundled_scenario_matches_its_golden(name, tmp_path):
    golden = goldens.golden_path(name)
    assert golden.stat().st_size < 1_000_000, f"{golden} is too large to commit"
    result = goldens.check(name, tmp_path)
    assert result.same, result.message()


@pytest.mark.slow
def test_a_changed_command_fails_the_golden_check_with_the_step(tmp_path):
    # The demo's client commands every 13 steps instead of 10: the arm's motion changes
    # from the first command that differs.
    edited = tmp_path / "scenarios" / "demo.yaml"
    edited.parent.mkdir()
    doc = yaml.safe_load(goldens.scenario_path("demo").read_text())
    assert doc["client"]["command"] == "python clients/demo_arm.py --seconds 5"
    doc["client"]["command"] = [
        "python",
        str(goldens.scenario_path("demo").parent / "clients" / "demo_arm.py"),
        "--seconds",
        "5",
        "--every",
        "13",
    ]
    edited.write_text(yaml.safe_dump(doc))
    result = goldens.check("demo", tmp_path / "run", scenario=edited)
    assert not result.same
    assert result.first_step is not None
    assert 10 <= result.first_step <= 30, result.message()
    message = result.message()
    assert f"at step {result.first_step}" in message
    assert "make goldens" in message


def test_golden_files_are_recordings_without_the_binary_model(tmp_path):
    for name in goldens.BUNDLED:
        with Recording(goldens.golden_path(name)) as rec:
            assert ATTACHMENT_MODEL_BINARY not in rec.attachment_names
            assert rec.metadata["state_every"] == str(goldens.STATE_EVERY)
            assert Path(rec.path).suffix == ".mcap"
