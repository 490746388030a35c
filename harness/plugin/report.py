"""What a failed test's report says about its harness: the ``harness`` section
(:func:`report_section`: recordings, events, bridge errors, the first golden divergence, then
the commands that reproduce, replay and open the run), the note left in the failed test's
folder for CI (:func:`write_failure_note`) and the bridge's error ``status`` frames
(:func:`bridge_errors`, which ``--harness-strict-bridge`` fails a test on).

This module imports only the standard library at import time; MCAP loads when the bridge
errors are first read back.
"""

from __future__ import annotations

import contextlib
import shlex
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from harness.plugin.goldens import rerun_command
from harness.plugin.run import FAILURE_NOTE

if TYPE_CHECKING:
    from harness.plugin.run import HarnessRun

__all__ = ["bridge_errors", "report_section", "write_failure_note"]


def bridge_errors(recordings: Iterable[Path]) -> list[str]:
    """Error ``status`` frames the bridge sent to clients, from the recordings (one line each:
    the step, the connection and the message); a recording not written is skipped."""
    import json

    from harness.recording import Recording
    from harness.rosbridge import DIRECTION_OUT

    found: list[str] = []
    for path in recordings:
        if not path.is_file():
            continue
        with Recording(path) as rec:
            for frame in rec.bridge_frames():
                if frame.op != "status" or frame.direction != DIRECTION_OUT:
                    continue
                with contextlib.suppress(ValueError):
                    status = json.loads(frame.text)
                    if status.get("level") == "error":
                        found.append(
                            f"step {frame.step}, connection {frame.connection}: "
                            f"{status.get('msg', '')}"
                        )
    return found


def report_section(run: HarnessRun) -> str:
    """The ``harness`` section of a failed test's report (empty when there is nothing to say).
    It ends with the commands that reproduce the test, replay its recordings and open them
    (``harness diff`` of the golden and what it was compared with when a golden differs)."""
    keep = run.settings.keep_recordings
    kept = keep != "never"
    lines: list[str] = []
    for path in run.recordings:
        fate = "kept" if kept else "removed after the test"
        lines.append(f"recording: {path} ({fate}: --harness-keep-recordings={keep})")
    for result in run.results:  # harness_scenario: the failed verdicts
        failed = [v for v in result.verdicts if not v.passed]
        if result.error:
            lines.append(f"scenario:  error: {result.error}")
        lines.extend(f"scenario:  {v.name}: {v.detail}" for v in failed)
        if not failed and not result.error:
            lines.append("scenario:  passed")
    for path in run.snapshots:
        lines.append(f"snapshot:  {path} (what golden.check() compared)")
    for sink in run.sinks:
        summary = sink.report_lines(max_lines=20)
        lines.append(f"events:    {summary[0] or 'none'}")
        lines.extend(f"           {line}" for line in summary[1:])
    if run.bridge_errors:
        lines.append(f"bridge:    {len(run.bridge_errors)} error status frame(s)")
        lines.extend(f"           {e}" for e in run.bridge_errors[:20])
    if run.divergence:
        lines.append(f"golden:    first divergence: {run.divergence}")
    elif run.golden_note:
        lines.append(f"golden:    {run.golden_note}")
    lines.extend(f"close:     {e}" for e in run.close_errors)
    if not lines:
        return ""
    lines.append(f"reproduce: {rerun_command(run.item, run.settings)}")
    if not kept:
        return "\n".join(lines)
    compared = [*run.snapshots[-1:], *run.recordings][:1]  # what golden.check() compared
    if run.divergence and run.golden is not None and compared:
        command = shlex.join(["harness", "diff", str(run.golden), str(compared[0])])
        lines.append(f"diff:      {command}")
    for path in run.recordings:
        lines.append(f"replay:    {shlex.join(['harness', 'replay', str(path)])}")
    for path in run.recordings:
        lines.append(
            f"open:      {shlex.join(['foxglove-studio', str(path)])}  # Foxglove desktop; "
            "or drop the file on https://app.foxglove.dev"
        )
    return "\n".join(lines)


def write_failure_note(run: HarnessRun, section: str, headline: str) -> Path | None:
    """Write :data:`~harness.plugin.run.FAILURE_NOTE` in the failed test's folder (its node
    id, the failure's last line and ``section``): the folder then explains itself when CI
    uploads it. ``None`` when the recordings are not kept or the folder does not exist."""
    if run.settings.keep_recordings == "never" or not run.folder.is_dir():
        return None
    path = run.folder / FAILURE_NOTE
    text = (
        f"{run.item.nodeid} failed: {headline}\n\n{section}\n"
        if headline
        else (f"{run.item.nodeid} failed\n\n{section}\n")
    )
    path.write_text(text, encoding="utf-8")
    return path
