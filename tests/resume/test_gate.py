"""A recording from someone else is data for a resume too: ``harness serve --from`` rebuilds
the model through the recordings' one gate, so a xacro payload in the sources never runs and
the resume is refused in one line, as ``harness replay --level full`` is."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.safety.test_recording_gate import _error_line, _harness, _payload, _rewrite
from tests.safety.test_recording_gate import recordings as recordings  # the fixture


@pytest.mark.parametrize("model_name", ["robot.urdf.xacro", "robot.urdf"])
def test_a_xacro_payload_never_runs_on_resume(
    recordings: dict[str, Path], tmp_path: Path, model_name: str
) -> None:
    marker = tmp_path / "MARKER"
    payload = _rewrite(
        recordings["session"], tmp_path / "payload.mcap",
        {f"model/{model_name}": _payload(marker)}, keep_mjb=True,
    )  # fmt: skip
    done = _harness("serve", "--from", payload, "--at", "10", "--port", "0", "--record",
                    tmp_path / "child.mcap")  # fmt: skip
    assert not marker.exists(), f"the recording ran code: {done.stdout}{done.stderr}"
    assert done.returncode == 2
    line = _error_line(done)
    assert f"source/model/{model_name}" in line
    assert "never expanded" in line
