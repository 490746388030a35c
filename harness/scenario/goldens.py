"""Golden recordings of the bundled scenarios: ``recordings/scenarios/<name>.mcap``.

Each bundled scenario (:data:`BUNDLED`: the demo arm, two arms) is run once, exactly as
``harness run`` runs an iteration (its own client, clock and seed), with the physics state
recorded every :data:`STATE_EVERY` steps; the recording, less its exact binary model (the
``model.mjb`` attachment, most of a file's size: :func:`harness.replay.diff` rebuilds the model
from the source attachments, or reads the MJCF one), is the golden. Each file stays well under
1 MB.

:func:`check` runs the scenario again and compares the new recording with the golden through
:func:`harness.replay.diff` (states at the steps both hold, collision events, message counts);
a behaviour change (a MuJoCo, numpy or harness change, a gain, a scenario's command) fails with
the first divergent step. ``make test`` runs the check (``tests/goldens``).

Updating them is one deterministic command (same scenarios, seeds and lockstep or paused
clocks every time)::

    make goldens          # = python -m harness.scenario.goldens --update
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from harness.errors import ConfigError
from harness.recording import ATTACHMENT_MODEL_BINARY, copy_recording
from harness.replay import Tolerances
from harness.scenario.runfile import load_run_file
from harness.scenario.runner import iteration_specs

__all__ = [
    "BUNDLED",
    "GOLDEN_DIR",
    "STATE_EVERY",
    "TOLERANCES",
    "GoldenCheck",
    "check",
    "golden_path",
    "main",
    "record",
    "scenario_path",
    "update",
    "write_golden",
]

ROOT = Path(__file__).resolve().parents[2]
"""The source checkout (``scenarios/`` and ``recordings/`` live at its top level)."""
BUNDLED: tuple[str, ...] = ("demo", "two-arms")
"""The bundled scenarios with a golden: ``scenarios/<name>.yaml``."""
GOLDEN_DIR = ROOT / "recordings" / "scenarios"
STATE_EVERY = 10
"""Steps between recorded physics states in a golden (a 5 s demo: 250 states)."""
TOLERANCES = Tolerances(joint_position=1e-9, joint_velocity=1e-7)
"""What the check tolerates: rounding noise only (a real change is orders of magnitude more)."""
UPDATE_COMMAND = "make goldens"


def scenario_path(name: str) -> Path:
    """``scenarios/<name>.yaml`` of the source checkout."""
    return ROOT / "scenarios" / f"{name}.yaml"


def golden_path(name: str) -> Path:
    """``recordings/scenarios/<name>.mcap`` of the source checkout."""
    return GOLDEN_DIR / f"{name}.mcap"


def record(scenario: Path, out_dir: Path, state_every: int = STATE_EVERY) -> Path:
    """Run ``scenario`` once as ``harness run`` would (physics state every ``state_every``
    steps) and return its recording; a failed iteration raises :class:`ConfigError`."""
    from harness.scenario.runner import session_iteration_runner

    config = load_run_file(scenario)
    plan = config.simulations[0]
    recording = dataclasses.replace(plan.scenario.recording, enabled=True, state_every=state_every)
    plan = dataclasses.replace(
        plan, scenario=dataclasses.replace(plan.scenario, recording=recording), iterations=1
    )
    config = dataclasses.replace(config, simulations=(plan,))
    (spec,) = iteration_specs(config, out_dir)
    result = session_iteration_runner()(spec)
    if result.recording is None or not result.recording.is_file():
        raise ConfigError(f"{scenario}: the run left no recording ({result.reason})")
    if not result.passed:
        raise ConfigError(f"{scenario}: the run failed: {result.reason}")
    return result.recording


def write_golden(recording: Path, target: Path) -> int:
    """Copy ``recording`` to ``target`` without its ``model.mjb`` attachment (written to a
    temporary file, then renamed); returns the file size."""
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.tmp")
    copy_recording(recording, tmp, drop={ATTACHMENT_MODEL_BINARY})
    tmp.replace(target)
    return target.stat().st_size


@dataclasses.dataclass(frozen=True)
class GoldenCheck:
    """The outcome of :func:`check`: ``first_step`` is the first divergent step (None when
    the run matches its golden, or when only step-less quantities differ)."""

    name: str
    golden: Path
    recording: Path
    same: bool
    first_step: int | None
    report: str

    def message(self) -> str:
        """One paragraph for a failing test: where it diverged and how to update."""
        if self.same:
            return f"golden {self.name}: same as {self.golden}"
        where = ""
        if self.first_step is not None:
            where = (
                f" at step {self.first_step} (the first recorded state that differs; states "
                f"are recorded every {STATE_EVERY} steps)"
            )
        return (
            f"golden {self.name}: the run diverges from {self.golden}{where}\n{self.report}\n"
            f"if the change is intended, update the goldens: {UPDATE_COMMAND}"
        )


def check(name: str, work_dir: Path, scenario: Path | None = None) -> GoldenCheck:
    """Run bundled scenario ``name`` (or ``scenario``, e.g. an edited copy) and compare it
    with ``recordings/scenarios/<name>.mcap``."""
    from harness.replay import diff

    golden = golden_path(name)
    if not golden.is_file():
        raise ConfigError(f"{golden}: no golden recording; create it with {UPDATE_COMMAND}")
    recording = record(scenario or scenario_path(name), work_dir)
    report = diff(golden, recording, TOLERANCES, ignore_after_last_step=True)
    steps = [e.step for e in report.entries if e.step >= 0]
    return GoldenCheck(
        name=name,
        golden=golden,
        recording=recording,
        same=report.same,
        first_step=min(steps) if steps else None,
        report=report.format(),
    )


def update(names: Sequence[str] = BUNDLED) -> list[tuple[Path, int]]:
    """Re-record the goldens of ``names``; returns each file and its size."""
    written = []
    with tempfile.TemporaryDirectory(prefix="harness-goldens-") as tmp:
        for name in names:
            recording = record(scenario_path(name), Path(tmp) / name)
            written.append((golden_path(name), write_golden(recording, golden_path(name))))
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m harness.scenario.goldens [--update] [NAME ...]``: check (default) or update
    the goldens of the bundled scenarios; exit 1 when a check diverges."""
    parser = argparse.ArgumentParser(
        prog="python -m harness.scenario.goldens", description=__doc__.splitlines()[0]
    )
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"of {', '.join(BUNDLED)}")
    parser.add_argument("--update", action="store_true", help="re-record the goldens")
    args = parser.parse_args(argv)
    names = tuple(args.names) or BUNDLED
    unknown = [n for n in names if n not in BUNDLED]
    if unknown:
        parser.error(f"no bundled scenario {unknown[0]!r} (bundled: {', '.join(BUNDLED)})")
    if args.update:
        for path, size in update(names):
            print(f"wrote {path.relative_to(ROOT)} ({math.ceil(size / 1024)} KiB)")
        return 0
    failed = 0
    with tempfile.TemporaryDirectory(prefix="harness-goldens-") as tmp:
        for name in names:
            result = check(name, Path(tmp) / name)
            print(result.message())
            failed += not result.same
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
