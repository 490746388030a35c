"""``harness inspect-model FILE [--json]``: links, joints and frames of a robot model.

Every pose is in the model frame at the zero configuration, as ``[x, y, z, qw, qx, qy, qz]``
(metres, unit quaternion). The JSON layout is a stable contract (see :func:`to_json`).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from harness.models.description import RobotModel

__all__ = [
    "add_arguments",
    "add_load_options",
    "add_robot_arg_option",
    "load_options",
    "robot_args",
    "run",
    "to_json",
]


def _robot_arg(text: str) -> tuple[str, str]:
    from harness.models.errors import XacroError
    from harness.models.xacro.expand import parse_robot_arg

    try:
        return parse_robot_arg(text)
    except XacroError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_robot_arg_option(parser: argparse.ArgumentParser) -> None:
    """``--robot-arg NAME:=VALUE`` (repeatable): an argument of a xacro robot."""
    parser.add_argument(
        "--robot-arg",
        dest="robot_args",
        metavar="NAME:=VALUE",
        type=_robot_arg,
        action="append",
        default=[],
        help="an argument of a xacro robot, as on the xacro command line (repeatable), "
        "e.g. --robot-arg ur_type:=ur5e",
    )


def robot_args(args: argparse.Namespace) -> dict[str, str]:
    """The ``--robot-arg`` values as a mapping (a later one wins)."""
    return dict(getattr(args, "robot_args", None) or [])


def add_load_options(parser: argparse.ArgumentParser, *, strict_only: bool = False) -> None:
    """``--self-collision``, ``--srdf``, ``--base``, ``--mesh-collision`` and ``--strict`` (the
    ``self_collision``, ``srdf``, ``base``, ``mesh_collision`` and ``strict`` options of
    :func:`harness.models.load_robot`); ``strict_only`` adds only ``--strict`` (a command
    that reads a description without simulating it)."""
    from harness.vocabulary import BASE_KINDS, MESH_COLLISION_MODES, SELF_COLLISION_POLICIES

    if not strict_only:
        parser.add_argument(
            "--self-collision",
            dest="self_collision",
            choices=SELF_COLLISION_POLICIES,
            default=None,
            help="which pairs of the robot's own links collide (default: the file's "
            "self_collide, else auto)",
        )
        parser.add_argument(
            "--srdf",
            metavar="PATH|package://PKG/PATH",
            default=None,
            help="the robot's SRDF (e.g. of its MoveIt config package): its "
            "<disable_collisions> pairs never collide",
        )
        parser.add_argument(
            "--base",
            choices=BASE_KINDS,
            default=None,
            help="fixed to the world or floating (default: as the file says; URDF: fixed)",
        )
        parser.add_argument(
            "--mesh-collision",
            dest="mesh_collision",
            choices=MESH_COLLISION_MODES,
            default=None,
            help="a non-convex collision mesh collides as convex pieces within 2 cm of its "
            "triangles (decompose, default) or as its convex hull (hull)",
        )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="refuse what a lenient load recovers or repairs (bad inertias, XML defects, ...)",
    )


def load_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options of :func:`add_load_options` given on the command line, as keyword
    arguments of :func:`harness.models.load_robot` (those not given are left out)."""
    options: dict[str, Any] = {}
    for name in ("self_collision", "srdf", "base", "mesh_collision"):
        value = getattr(args, name, None)
        if value is not None:
            options[name] = value
    if getattr(args, "strict", False):
        options["strict"] = True
    return options


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``harness inspect-model``."""
    parser.add_argument(
        "file", help='a .urdf, .xacro, .sdf/.world or MJCF file, package://pkg/path, or "demo"'
    )
    parser.add_argument("--json", action="store_true", help="print the JSON contract")
    add_robot_arg_option(parser)
    add_load_options(parser, strict_only=True)


def to_json(model: RobotModel) -> dict[str, Any]:
    """``{"model", "links": [{"name", "pose"}], "joints": [{"name", "type", "parent",
    "child", "pose", "axis", "limits": {"lower", "upper", "velocity", "effort"}}],
    "frames": [{"name", "attached_to", "pose"}]}``; absent limits are ``null``."""
    return {
        "model": model.name,
        "links": [{"name": link.name, "pose": link.pose.as_list()} for link in model.links],
        "joints": [
            {
                "name": j.name,
                "type": j.type,
                "parent": j.parent,
                "child": j.child,
                "pose": j.pose.as_list(),
                "axis": list(j.axis),
                "limits": {
                    "lower": j.limits.lower,
                    "upper": j.limits.upper,
                    "velocity": j.limits.velocity,
                    "effort": j.limits.effort,
                },
            }
            for j in model.joints
        ],
        "frames": [
            {"name": f.name, "attached_to": f.attached_to, "pose": f.pose.as_list()}
            for f in model.frames
        ],
    }


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def _pose(values: list[float]) -> str:
    return " ".join(f"{v:8.4f}" for v in values)


def format_table(model: RobotModel) -> str:
    """The human-readable listing."""
    lines = [
        f"model {model.name} ({model.format}, {model.source})",
        "",
        "links (pose in model frame: x y z qw qx qy qz)",
    ]
    width = max((len(link.name) for link in model.links), default=4)
    for link in model.links:
        mass = f"  mass {link.inertial.mass:.4g}" if link.inertial else ""
        lines.append(f"  {link.name:<{width}}  {_pose(link.pose.as_list())}{mass}")
    lines += ["", "joints (axis in model frame; limits lower upper velocity effort)"]
    width = max((len(j.name) for j in model.joints), default=4)
    for j in model.joints:
        lim = j.limits
        mimic = f"  mimic {j.mimic.joint}" if j.mimic else ""
        lines.append(
            f"  {j.name:<{width}}  {j.type:<10} {j.parent} -> {j.child}  "
            f"axis {_pose(list(j.axis))}  limits {_num(lim.lower)} {_num(lim.upper)} "
            f"{_num(lim.velocity)} {_num(lim.effort)}{mimic}"
        )
    if model.frames:
        lines += ["", "frames"]
        for f in model.frames:
            lines.append(f"  {f.name} (on {f.attached_to})  {_pose(f.pose.as_list())}")
    if model.xacro is not None:
        args = " ".join(f"{k}:={v}" for k, v in model.xacro.args.items())
        lines += ["", f"expanded from {model.xacro.source}" + (f" with {args}" if args else "")]
    if model.ros2_control is not None:
        lines += ["", "ros2_control (joint: command interfaces; initial position)"]
        for block in model.ros2_control.blocks:
            note = "" if block.simulated else " (a real driver: the simulation stands in)"
            lines.append(f"  {block.name}: {block.plugin or 'no plugin'}{note}")
            for joint in block.joints:
                initial = joint.initial_position
                lines.append(
                    f"    {joint.name}: {', '.join(joint.command_names) or '-'}"
                    + ("" if initial is None else f"; {initial:.4g}")
                )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Print the description of ``args.file``."""
    from pathlib import Path

    from harness.models.build.load import load_description
    from harness.models.sdf.worldfile import is_sdf_world, world_description

    if is_sdf_world(Path(args.file)):  # every model of the world, names scoped model::link
        model = world_description(args.file)
    else:
        model = load_description(args.file, robot_args=robot_args(args), strict=args.strict)
    if args.json:
        print(json.dumps(to_json(model), indent=2))
    else:
        print(format_table(model))
    return 0
