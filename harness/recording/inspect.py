"""``inspect``: what a recording holds and whether it is sound, as a report (text or JSON)."""

from __future__ import annotations

import os
import warnings
from typing import Any

from harness.errors import RecordingError
from harness.recording.errors import RecordingDamagedWarning, RecordingFormatError
from harness.recording.recording import Recording
from harness.recording.sourcelinks import ATTACHMENT_SOURCE_REFS, PROJECT_REFERENCE_REFUSAL

__all__ = ["VERDICT_DAMAGED", "VERDICT_OK", "VERDICT_TRUNCATED", "format_report", "inspect"]

VERDICT_OK = "ok"
VERDICT_TRUNCATED = "truncated"
VERDICT_DAMAGED = "damaged"


def inspect(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A JSON-ready report of the recording at ``path``: duration, topics, metadata,
    attachments, validation and a verdict (``ok``, ``truncated``: cut short, e.g. a killed
    recorder; ``damaged``: corrupt bytes or an inconsistent summary). Unreadable files raise
    :class:`~harness.recording.errors.RecordingFormatError`, and so does a golden that refers
    to its project's files (:data:`~harness.recording.sourcelinks.ATTACHMENT_SOURCE_REFS`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RecordingDamagedWarning)
        recording = Recording(path)
    with recording:
        if ATTACHMENT_SOURCE_REFS in recording.attachment_names:
            raise RecordingFormatError(f"{recording.path}: {PROJECT_REFERENCE_REFUSAL}")
        s = recording.scan
        problems: list[dict[str, Any]] = [
            {"offset": p.offset, "message": p.message} for p in s.problems
        ]
        try:
            epochs = [
                {"step": e.step, "epoch": e.epoch, "reason": e.reason} for e in recording.epochs()
            ]
        except RecordingError as exc:
            epochs = []
            problems.append({"offset": -1, "message": f"epochs unreadable: {exc}"})
        if not problems:
            verdict = VERDICT_OK
        elif all(str(p["message"]).startswith("truncated") for p in problems):
            verdict = VERDICT_TRUNCATED
        else:
            verdict = VERDICT_DAMAGED
        start, end = s.start_time, s.end_time
        return {
            "path": str(recording.path),
            "size_bytes": s.size,
            "verdict": verdict,
            "problems": problems,
            "readable_up_to_byte": s.truncated_at,
            "lost": [
                {
                    "offset": r.offset,
                    "end": r.end,
                    "first_step": r.first_step,
                    "last_step": r.last_step,
                    "what": r.what,
                }
                for r in recording.lost
            ],
            "profile": recording.profile,
            "library": recording.library,
            "duration": {
                "first_step": recording.first_step if start >= 0 else None,
                "last_step": recording.last_step if end >= 0 else None,
                "steps": recording.last_step - recording.first_step + 1 if end >= 0 else 0,
                "start_sim_time_ns": start if start >= 0 else None,
                "end_sim_time_ns": end if end >= 0 else None,
                "sim_time_s": (end - start) / 1e9 if end >= 0 else 0.0,
            },
            "messages": recording.message_count,
            "epochs": epochs,
            "topics": [t._asdict() for t in recording.topics.values()],
            "metadata": recording.all_metadata,
            "attachments": [
                {"name": a.name, "media_type": a.media_type, "bytes": a.data_length}
                for a in s.attachments
            ],
            "validation": {
                "chunks": len(s.chunks),
                "chunk_crcs_checked": len(s.chunks),
                "data_section_crc_checked": s.data_crc_checked,
                "summary_present": s.has_summary,
                "summary_crc_checked": s.summary_crc_checked,
                "summary_consistency_checks": s.summary_checks,
            },
        }


def format_report(report: dict[str, Any]) -> str:
    """The report as text for a terminal."""
    d = report["duration"]
    v = report["validation"]
    lines = [
        f"{report['path']}  ({report['size_bytes']} bytes, profile {report['profile']}, "
        f"{report['library']})",
        f"duration: {d['steps']} steps (step {d['first_step']} to {d['last_step']}), "
        f"{d['sim_time_s']:.6f} s sim time",
        f"messages: {report['messages']}",
    ]
    epochs = report.get("epochs", [])
    if epochs:
        listed = ", ".join(f"{e['reason']} after step {e['step']}" for e in epochs[:10])
        more = f" and {len(epochs) - 10} more" if len(epochs) > 10 else ""
        lines.append(f"epochs: {len(epochs)} ({listed}{more}): replay continues from each")
    lines.append("topics:")
    width = max((len(t["topic"]) for t in report["topics"]), default=0)
    lines += [
        f"  {t['topic']:<{width}}  {t['messages']:>9}  {t['msgtype']}" for t in report["topics"]
    ]
    for name, record in report["metadata"].items():
        lines.append(f"metadata {name!r}:")
        lines += [f"  {key} = {value}" for key, value in record.items()]
    lines.append("attachments:")
    lines += [
        f"  {a['name']}  ({a['media_type']}, {a['bytes']} bytes)" for a in report["attachments"]
    ]
    lines.append(
        f"validation: {v['chunk_crcs_checked']} chunk CRCs checked; data section CRC "
        f"{'checked' if v['data_section_crc_checked'] else 'not checked'}; summary "
        + (
            f"CRC {'checked' if v['summary_crc_checked'] else 'not checked'}, "
            f"{v['summary_consistency_checks']} consistency checks"
            if v["summary_present"]
            else "missing"
        )
    )
    for p in report["problems"]:
        lines.append(f"problem at byte {p['offset']}: {p['message']}")
    for r in report.get("lost", []):
        last = "the end" if r["last_step"] is None else f"step {r['last_step']}"
        lines.append(
            f"lost: bytes {r['offset']}..{r['end']} passed over; messages of step "
            f"{r['first_step']} to {last} may be missing, the rest reads"
        )
    verdict = report["verdict"].upper()
    if report["readable_up_to_byte"] is not None:
        verdict += f": readable up to byte {report['readable_up_to_byte']}"
    lines.append(f"verdict: {verdict}")
    return "\n".join(lines)
