"""Golden recordings: :class:`Golden` (the ``golden`` fixture's value: ``golden.check()``
compares this test's recording so far with its golden through :func:`harness.replay.diff`),
:class:`GoldenMismatch`, the golden's path (:func:`golden_path`, :func:`mode_label`) and the
command that writes it (:func:`update_command`).

This module imports only the standard library, pytest and :mod:`harness.vocabulary` at import
time; the replay package loads when a golden is first checked.
"""

from __future__ import annotations

import contextlib
import math
import os
import shlex
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from harness.plugin.run import safe_name
from harness.plugin.settings import HarnessSettings

if TYPE_CHECKING:
    from harness.plugin.run import HarnessRun
    from harness.replay import DiffEntry, DiffReport

__all__ = [
    "GOLDENS_UNKNOWN_PLATFORM",
    "GOLDENS_WRITTEN",
    "Golden",
    "GoldenMismatch",
    "golden_path",
    "mode_label",
    "rerun_command",
    "update_command",
]

_DEFAULT_MODE = "position"  # harness.models.load_robot's control default

GOLDENS_WRITTEN = pytest.StashKey[list[Path]]()
"""The goldens ``--harness-update-goldens`` wrote in this run: ``config.stash[GOLDENS_WRITTEN]``."""
GOLDENS_UNKNOWN_PLATFORM = pytest.StashKey[list[Path]]()
"""The goldens checked in this run that carry no platform fingerprint (written by an older
harness): listed once at the end of the run."""


class GoldenMismatch(AssertionError):
    """This test's recording differs from its golden beyond the tolerances."""


# the failure line users see (and grep in CI) names the class where it is imported from
GoldenMismatch.__module__ = "harness.pytest_plugin"


class Golden:
    """This test's golden recording: :attr:`path`, :meth:`check`."""

    def __init__(self, run: HarnessRun) -> None:
        self._run = run

    @property
    def path(self) -> Path:
        """``<golden dir>/<test module>/<test name>[<mode>].mcap`` (the mode only when it is
        not the default; see :mod:`harness.pytest_plugin`)."""
        return golden_path(self._run.item, self._run.settings, self._run.session_mode())

    def check(self, **tolerances: float) -> DiffReport:
        """Compare this test's recording so far (a snapshot: the session keeps running) with
        the golden (or write the golden under ``--harness-update-goldens``). ``tolerances``:
        per-quantity bounds (:class:`harness.replay.Tolerances` fields; default 0: exact).
        Raises :class:`GoldenMismatch` naming the first divergence."""
        __tracebackhide__ = True  # the failure shows the test's line, not this method's
        from harness.plugin.golden_sources import (
            GoldenSourcesChanged,
            resolved_golden,
            write_golden,
        )
        from harness.recording import compare_fingerprints
        from harness.replay import PlatformMismatchError, Tolerances, diff

        run = self._run
        unknown = sorted(set(tolerances) - set(Tolerances._fields))
        if unknown:
            raise TypeError(
                f"golden.check: unknown tolerance {unknown[0]!r} "
                f"(known: {', '.join(Tolerances._fields)})"
            )
        if not run.recordings:
            raise pytest.UsageError(
                f"{run.item.nodeid}: golden.check() needs this test's harness_session"
            )
        recording = run.recordings[0]
        session = run.sessions[0]
        if not session.closed:
            snapshot = recording.with_name(f"{recording.stem}.snapshot.mcap")
            session.snapshot(snapshot)
            if snapshot not in run.snapshots:
                run.snapshots.append(snapshot)
            recording = snapshot
        golden = self.path
        run.golden = golden
        shown = _shown(golden, run.settings.rootdir)
        settings = run.settings
        if settings.update_goldens:
            write_golden(
                recording,
                golden,
                sources=settings.golden_sources,
                rootdir=settings.rootdir,
                skip=(settings.record_dir, settings.golden_dir),
            )
            run.item.config.stash[GOLDENS_WRITTEN].append(golden)
            run.golden_note = f"written {shown}"
        elif not golden.is_file():
            run.golden_note = f"missing {shown}"
            pytest.fail(
                f"golden recording {shown} does not exist; create it with:\n"
                f"    {update_command(run.item, settings)}",
                pytrace=False,
            )
        bounds: dict[str, Any] = dict(tolerances)
        changed = ""
        try:
            with resolved_golden(golden, settings.rootdir) as full:
                report = diff(full, recording, Tolerances(**bounds), ignore_after_last_step=True)
        except PlatformMismatchError as exc:
            parts = compare_fingerprints(*exc.fingerprints, ("in the golden", "here")).text
        except GoldenSourcesChanged as exc:
            parts, changed = "", str(exc)
        else:
            parts = ""
        if changed:  # one line, no traceback
            run.golden_note = "its sources changed"
            pytest.fail(
                f"{changed}; if the change is intended: {update_command(run.item, settings)}",
                pytrace=False,
            )
        if parts:  # failed outside the except block: the one line, no chained traceback
            run.golden_note = f"recorded on another platform ({parts})"
            pytest.fail(
                f"golden {shown} was recorded on another platform ({parts}): an exact golden "
                "check holds only on the same platform; give tolerances, e.g. "
                "golden.check(joint_position=1e-9, joint_velocity=1e-7), or write the golden "
                f"here: {update_command(run.item, run.settings)}",
                pytrace=False,
            )
        if any(note.startswith("no platform fingerprint in A") for note in report.notes):
            run.item.config.stash[GOLDENS_UNKNOWN_PLATFORM].append(golden)
        first = report.first_entry
        if first is not None:
            run.divergence = _format_entry(first)
            raise GoldenMismatch(
                f"this run differs from golden {shown}: first divergence: {run.divergence}\n"
                f"{report.format()}\n"
                f"if the change is intended: {update_command(run.item, run.settings)}"
            )
        return report


def golden_path(item: pytest.Item, settings: HarnessSettings, mode: Any) -> Path:
    """``<golden dir>/<test module>/[<class>.]<test name>[<mode>].mcap`` (:func:`mode_label`)."""
    module = Path(item.nodeid.split("::", 1)[0]).stem
    name = safe_name(item.name)
    cls = getattr(item, "cls", None)
    if cls is not None:
        name = f"{cls.__name__}.{name}"
    return settings.golden_dir / module / f"{name}{mode_label(mode)}.mcap"


def rerun_command(item: pytest.Item, settings: HarnessSettings, *extra: str) -> str:
    """The command that runs ``item`` again as this run did (its suite switches: the
    actuation), from the invocation directory, with ``extra`` arguments."""
    nodepath, _, rest = item.nodeid.partition("::")
    where = os.path.relpath(settings.rootdir / nodepath, item.config.invocation_params.dir)
    target = f"{where}::{rest}" if rest else where
    args = ["python", "-m", "pytest", target, *extra]
    if settings.actuation is not None:
        args.append(f"--harness-actuation={settings.actuation.value}")
    return shlex.join([*args, *settings.plugin_args])


def update_command(item: pytest.Item, settings: HarnessSettings) -> str:
    """The command that writes ``item``'s golden, run from the invocation directory."""
    return rerun_command(item, settings, "--harness-update-goldens")


def mode_label(mode: Any) -> str:
    """The golden-name suffix of a control mode: ``""`` for the default (every joint
    ``position``), ``"[kinematic]"``, or the joints that differ, ``"[j1=velocity,j2=effort]"``."""
    if isinstance(mode, Mapping):
        changed = sorted((str(j), str(m)) for j, m in mode.items() if m != _DEFAULT_MODE)
        return f"[{','.join(f'{j}={m}' for j, m in changed)}]" if changed else ""
    if mode is None or mode == _DEFAULT_MODE:
        return ""
    return f"[{mode}]"


def _shown(path: Path, rootdir: Path) -> str:
    with contextlib.suppress(ValueError):
        return str(path.relative_to(rootdir))
    return str(path)


def _format_entry(e: DiffEntry) -> str:
    """``joint_position joint3 at step 41: golden 0.1, this run 0.1002 (delta 0.0002 there >
    tolerance 0; max delta 0.005 at step 90)``: each value says at which step it is."""
    if e.step < 0:
        return (
            f"{e.quantity} {e.name}: golden {e.a!r}, this run {e.b!r} "
            f"(delta {e.max_delta:.6g} > tolerance {e.tolerance:g})"
        )
    delta = "" if math.isnan(e.delta) else f"delta {e.delta:.6g} there > "
    largest = f"; max delta {e.max_delta:.6g} at step {e.max_step}" if e.max_step >= 0 else ""
    return (
        f"{e.quantity} {e.name} at step {e.step}: golden {e.a!r}, this run {e.b!r} "
        f"({delta}tolerance {e.tolerance:g}{largest})"
    )
