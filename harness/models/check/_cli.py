"""``harness check-model FILE [--json] [--robot-arg NAME:=VALUE ...]
[--self-collision auto|off|on|srdf] [--srdf PATH] [--base fixed|floating] [--strict]``:
a robot's report.

Exit code 0 when the robot behaves, 1 with the reasons when it does not, 2 when it does not
load (see :mod:`harness.models.check.report`).
"""

from __future__ import annotations

import argparse
import json

from harness.models._cli import add_load_options, add_robot_arg_option, load_options, robot_args
from harness.models.check.report import ModelCheck, check_model

__all__ = ["add_arguments", "format_report", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``harness check-model``."""
    parser.add_argument(
        "file", help='a .urdf, .xacro, .sdf/.world or MJCF file, package://pkg/path, or "demo"'
    )
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    add_robot_arg_option(parser)
    add_load_options(parser)


def _value(value: float | None, scale: float = 1.0, unit: str = "") -> str:
    return "-" if value is None else f"{value * scale:.3g}{unit}"


def format_report(report: ModelCheck) -> str:
    """The human-readable report."""
    if report.error is not None:
        return f"{report.source}: does not load: {report.error}"
    lines = [f"{report.source}: {report.base} base, {len(report.joints)} actuated joint(s)"]
    for title, items in (("load notes", report.notes), ("repairs", report.repairs)):
        if items:
            lines.append(f"{title}:")
            lines += [f"  {item}" for item in items]
    collision = report.self_collision
    if collision:
        ignored = collision.get("ignored", [])
        lines.append(
            f"self-collision: {collision.get('policy')} ({collision.get('origin')}), "
            f"{len(ignored)} pair(s) ignored"
        )
        lines += [f"  {a} / {b}: {why}" for a, b, why in ignored]
    if report.start_contacts:
        lines.append("contacts at the start:")
        lines += [f"  {a} / {b}: {d * 1000:.2f} mm" for a, b, d in report.start_contacts]
    lines.append("joint  hold  overshoot  settling  peak-speed/limit")
    for joint in report.joints:
        unit = " mm" if joint.prismatic else " mrad"
        lines.append(
            f"  {joint.name}  {_value(joint.hold_error, 1000, unit)}"
            f"  {_value(joint.overshoot, 100, '%')}  {_value(joint.settling_time, 1, ' s')}"
            f"  {_value(joint.peak_speed)}/{_value(joint.velocity_limit)}"
        )
    if report.kinematic_drift is not None:
        lines.append(f"kinematic hold: other joints drift {report.kinematic_drift:.3g}")
    if report.stand is not None:
        stand = report.stand
        lines.append(
            f"stand {stand.seconds:g} s: {'ok' if stand.stood else 'FAILED'}, base height "
            f"{stand.start_height:.3f} -> {stand.end_height:.3f} m"
        )
    mass = report.mass
    if mass:
        lines.append(
            f"mass: {mass['total_kg']:.3g} kg in {mass['links']:.0f} links, lightest moving "
            f"{mass['lightest_moving_kg']:.3g} kg, smallest moving inertia "
            f"{mass['smallest_moving_inertia_kg_m2']:.3g} kg m^2"
        )
    lines += [f"hint: {hint}" for hint in report.hints]
    if report.problems:
        lines.append("does not behave:")
        lines += [f"  {problem}" for problem in report.problems]
    else:
        lines.append("behaves: no problem found")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Check ``args.file``; the exit code is the report's."""
    report = check_model(args.file, robot_args=robot_args(args), **load_options(args))
    if args.json:
        print(json.dumps(report.as_dict(), indent=2))
    else:
        print(format_report(report))
    return report.exit_code
