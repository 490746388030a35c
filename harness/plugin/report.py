"""What a failed test's report says about its harness: the ``harness`` section
(:func:`report_section`: recordings, the ``harness replay`` command, events, bridge errors,
the first golden divergence) and the bridge's error ``status`` frames
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

if TYPE_CHECKING:
    from harness.plugin.run import HarnessRun

__all__ = ["bridge_errors", "report_section"]


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
    """The ``harness`` section of a failed test's report (empty when there is nothing to say)."""
    keep = run.settings.keep_recordings
    lines: list[str] = []
    for path in run.recordings:
        fate = "removed after the test" if keep == "never" else "kept"
        lines.append(f"recording: {path} ({fate}: --harness-keep-recordings={keep})")
        lines.append(f"replay:    {shlex.join(['harness', 'replay', str(path)])}")
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
    return "\n".join(lines)
