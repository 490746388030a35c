"""The source links of a recording (``source-links.json``: a name laid out from another
attachment's bytes) go through the recording gate: every name and target a plain relative
path, the target one of the recording's ``source/`` attachments, bounded in count; anything
else is refused with one line before a file is written."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from harness.recording import Recording
from harness.recording.sourcelinks import MAX_SOURCE_LINKS
from harness.replay.errors import UnsafeRecordingError
from harness.replay.source import rebuild_robot
from harness.session import Session
from tests.replay import mcap_edit


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("links") / "demo.mcap"
    with Session("demo", record_to=path) as session:
        session.step(5)
    return path


def _with_links(src: Path, dst: Path, links: bytes) -> Path:
    """``src`` without ``model.mjb`` (the rebuild reads the sources), ``links`` as its
    ``source-links.json``."""

    def edit(attachments: dict[str, bytes]) -> dict[str, bytes]:
        kept = {n: b for n, b in attachments.items() if n != "model.mjb"}
        return {**kept, "source-links.json": links}

    mcap_edit.rewrite(src, dst, attachments=edit)
    return dst


CASES = {
    "name-leaves": ({"../../outside.stl": "model/demo_arm.urdf"}, "is not a plain relative name"),
    "absolute-target": ({"model/x.stl": "/etc/hostname"}, "is not a plain relative name"),
    "target-absent": ({"model/x.stl": "model/absent.stl"}, "which is not attached"),
    "name-attached": ({"model/demo_arm.urdf": "scene/table.xml"}, "is also attached"),
    "too-many": (
        {f"model/m{i}.stl": "model/demo_arm.urdf" for i in range(MAX_SOURCE_LINKS + 1)},
        f"more than the limit of {MAX_SOURCE_LINKS}",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_bad_link_is_refused_in_one_line(demo: Path, tmp_path: Path, case: str) -> None:
    links, reason = CASES[case]
    with Recording(demo) as rec:
        assert "source/model/demo_arm.urdf" in rec.attachment_names
        assert "source/scene/table.xml" in rec.attachment_names
    path = _with_links(demo, tmp_path / "bad.mcap", json.dumps(links).encode())
    with Recording(path) as rec, pytest.raises(UnsafeRecordingError) as info:
        rebuild_robot(rec)
    message = str(info.value)
    assert reason in message
    assert "\n" not in message
    assert "source-links.json" in message


def test_links_that_are_not_json_are_refused_by_the_cli_in_one_line(
    demo: Path, tmp_path: Path
) -> None:
    path = _with_links(demo, tmp_path / "bad.mcap", b"{not json")
    done = subprocess.run(
        [sys.executable, "-m", "harness", "replay", "--level", "full", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode != 0
    assert "Traceback" not in done.stderr
    [line] = done.stderr.strip().splitlines()
    assert "source-links.json" in line, line
    assert "not JSON" in line, line


def test_a_good_link_lays_out_the_name_from_the_attachment(demo: Path, tmp_path: Path) -> None:
    # the scene laid out a second time under another name: the rebuild is unchanged
    path = _with_links(
        demo, tmp_path / "good.mcap", json.dumps({"extra/copy.xml": "scene/table.xml"}).encode()
    )
    with Recording(path) as rec:
        assert rebuild_robot(rec).sha256 == rec.metadata["model_sha256"]
