"""``harness serve``: a simulated robot on a rosbridge server until Ctrl-C (or SIGTERM).

Prints the URL on its first line (``harness serve: ws://127.0.0.1:PORT ...``); on SIGINT or
SIGTERM it closes the session cleanly (the recording, when ``--record``, is complete) and
prints the step reached. ``--token`` (or ``$HARNESS_TOKEN``) makes clients present a token
(``ws://host:port/?token=...``; the printed URL carries it).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import warnings
from pathlib import Path
from types import FrameType
from typing import Any

from harness.errors import HarnessError, RecordingError
from harness.models import add_load_options, add_robot_arg_option, load_options, robot_args
from harness.session.live._cli_resume import run_resumed
from harness.vocabulary import CLOCK_MODES, CONTROL_MODE_INPUTS, LIMIT_POLICIES, ControlMode

__all__ = ["add_arguments", "run", "what_was_kept"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``harness serve``."""
    parser.add_argument(
        "--robot",
        default="demo",
        help="robot model file (.urdf, .xacro, .sdf, MJCF), package://pkg/path or 'demo' (default)",
    )
    add_robot_arg_option(parser)
    add_load_options(parser)
    parser.add_argument(
        "--mode",
        choices=CONTROL_MODE_INPUTS,
        default="position",
        help="control mode of every joint ('dynamic' is 'position')",
    )
    parser.add_argument(
        "--kinematic-limits",
        choices=LIMIT_POLICIES,
        default="clamp",
        help="kinematic commands beyond a joint's limits: clamp (default) or allow",
    )
    parser.add_argument(
        "--clock", choices=CLOCK_MODES, default=None, help="clock mode (default realtime)"
    )
    parser.add_argument(
        "--rate", type=float, default=1.0, help="realtime: sim time per wall time (default 1)"
    )
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=9090, help="port (default 9090; 0: any)")
    parser.add_argument("--namespace", default="", help="robot topics under /NAMESPACE/")
    parser.add_argument(
        "--scene", "--world", default=None, help="scene name, MJCF scene or SDF world file"
    )
    parser.add_argument(
        "--pose",
        metavar="X Y Z [ROLL PITCH YAW]",
        nargs="+",
        type=float,
        action=_PoseAction,
        default=None,
        help="where the robot's model frame is in the world (metres, radians; as a Gazebo "
        "launch's `create -x X -y Y -z Z -R ROLL -P PITCH -Y YAW`; default: the origin)",
    )
    parser.add_argument("--record", metavar="PATH", default=None, help="record the run to MCAP")
    parser.add_argument(
        "--controllers",
        metavar="FILE",
        action="append",
        default=None,
        help="ros2_control controllers YAML; repeatable: the files merge in order, as "
        "--params-file does (default: joint_state_broadcaster, joint_trajectory_controller, "
        "a gripper controller where the robot has fingers)",
    )
    parser.add_argument(
        "--controllers-arg",
        dest="controllers_args",
        metavar="NAME:=VALUE",
        type=_controllers_arg,
        action="append",
        default=[],
        help="the value of $(var NAME) in the controllers YAML, as a launch argument "
        "(repeatable), e.g. --controllers-arg joint_prefix:=joint",
    )
    parser.add_argument(
        "--token",
        default=os.environ.get("HARNESS_TOKEN") or None,
        help="clients must present this token: ws://HOST:PORT/?token=TOKEN "
        "(default: $HARNESS_TOKEN; none when unset)",
    )
    parser.add_argument(
        "--connect",
        metavar="URL",
        default=None,
        help="client mode: connect to the external rosbridge server at URL instead of serving "
        "(a token goes in the URL: ws://HOST:PORT/?token=TOKEN)",
    )
    parser.add_argument(
        "--connect-allow-refused",
        action="store_true",
        help="client mode: run even when the server refuses some of the simulation's topics "
        "or services (they are left out)",
    )
    parser.add_argument(
        "--ros2",
        action="store_true",
        help="also put the simulation on DDS for ROS 2 nodes (rclpy gateway; see README)",
    )
    resume = parser.add_argument_group(
        "resume a recording (harness.resume): the run continues bit-exactly from a step"
    )
    resume.add_argument(
        "--from",
        dest="resume_from",
        metavar="RUN.mcap",
        default=None,
        help="continue this session recording live: its robot, world and options are the "
        "recording's; the recorded clients become ghost peers; paused (lockstep: time moves "
        "when a client steps)",
    )
    at = resume.add_mutually_exclusive_group()
    at.add_argument(
        "--at", dest="resume_at", type=int, metavar="STEP", default=None,
        help="--from: the step to continue from (default: the recording's last step)",
    )  # fmt: skip
    at.add_argument(
        "--at-time", dest="resume_at_time", type=float, metavar="SECONDS", default=None,
        help="--from: the sim time to continue from (the nearest step)",
    )  # fmt: skip
    resume.add_argument(
        "--preroll", type=float, metavar="SECONDS", default=0.0,
        help="--from: play each attaching client the recorded outgoing frames and /clock of "
        "the SECONDS of sim time before the step, so its own state can catch up",
    )  # fmt: skip
    resume.add_argument(
        "--set", dest="resume_edits", metavar="KIND.TARGET=VALUE", action="append", default=[],
        help="--from: a fork edit applied at the step and recorded as its input (repeatable), "
        "e.g. joint.joint1=0.4",
    )  # fmt: skip


class _PoseAction(argparse.Action):
    """``--pose``: 3 or 6 numbers, each finite."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        numbers = [float(v) for v in values]
        if len(numbers) not in (3, 6) or not all(math.isfinite(v) for v in numbers):
            parser.error(
                f"argument --pose: expected X Y Z or X Y Z ROLL PITCH YAW (finite numbers), "
                f"got {' '.join(str(v) for v in values)}"
            )
        setattr(namespace, self.dest, numbers)


def _controllers_arg(text: str) -> tuple[str, str]:
    """One ``--controllers-arg NAME:=VALUE``."""
    from harness.controllers import ARG_NAME

    name, sep, value = text.partition(":=")
    if not sep or not ARG_NAME.match(name):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not NAME:=VALUE (a launch argument of the controllers YAML)"
        )
    return name, value


def run(args: argparse.Namespace) -> int:
    """Serve until SIGINT/SIGTERM; exit 0 after a clean shutdown."""
    from harness.rosbridge import ExposedServerWarning, is_loopback
    from harness.session.live.session import Session
    from harness.session.live.upstream import redact

    if args.connect is not None and args.token:
        print(
            "harness serve: error: --token protects the embedded server; with --connect put "
            "the external server's token in the URL (ws://HOST:PORT/?token=TOKEN)",
            file=sys.stderr,
        )
        return 2
    if args.connect is None and not is_loopback(args.host):
        guard = "clients must present the token" if args.token else "no token: use --token"
        print(
            f"harness serve: warning: binding {args.host} exposes the simulation to the "
            f"network; {guard}",
            file=sys.stderr,
        )
    # this line says it once; the server's own ExposedServerWarning would repeat it
    warnings.filterwarnings("ignore", category=ExposedServerWarning)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    if args.resume_from is not None:
        return run_resumed(args)
    if args.resume_at is not None or args.resume_at_time is not None or args.resume_edits:
        print(
            "harness serve: error: --at, --at-time and --set need --from RUN.mcap", file=sys.stderr
        )
        return 2
    args.clock = args.clock or "realtime"
    # Installed once the robot is loaded: during the load SIGTERM ends the process and SIGINT
    # raises KeyboardInterrupt (exit 130) as they do by default, instead of waiting for it.
    previous: dict[int, Any] = {}
    reached: tuple[int, int] | None = None  # step and dt once the session ran
    try:
        robot: Any = args.robot
        mode: ControlMode | None = ControlMode.parse(args.mode, "--mode")
        with Session(
            robot,
            mode=mode,
            kinematic_limits=args.kinematic_limits,
            clock=args.clock,
            rate=args.rate,
            namespace=args.namespace,
            host=args.host,
            port=args.port,
            token=args.token,
            connect_to=args.connect,
            connect_allow_refused=args.connect_allow_refused,
            ros2=args.ros2,
            record_to=args.record,
            scene=args.scene,
            pose=args.pose,
            robot_args=robot_args(args),
            **load_options(args),
            controllers=[Path(p) for p in args.controllers] if args.controllers else None,
            controllers_args=dict(args.controllers_args),
        ) as session:
            previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
            clock = f"{args.clock} x{args.rate:g}" if args.clock == "realtime" else args.clock
            where = session.url if args.connect is None else f"connected to {redact(session.url)}"
            extra = f", ROS 2 on domain {session.ros_domain_id}" if args.ros2 else ""
            print(
                f"harness serve: {where} robot {session.robot_name} "
                f"({ControlMode.parse(args.mode)}), "
                f"clock {clock}{extra}; Ctrl-C to stop",
                flush=True,
            )
            while not stop.wait(0.5) and session.failure is None:
                pass
            step = session.step_index
            reached = step, session.dt_ns
            failure = session.failure
            upstream = session.upstream
        if upstream is not None:
            print(f"harness serve: upstream: {upstream.summary()}", flush=True)
        recorded = f", recording {args.record} closed" if args.record else ""
        if failure is not None:
            if isinstance(failure, RecordingError) and args.record:
                recorded = f"; {what_was_kept(Path(args.record), step, session.dt_ns)}"
            print(f"harness serve: error: {failure}{recorded}", file=sys.stderr)
            return 1
        print(f"harness serve: stopped at step {step}{recorded}", flush=True)
    except RecordingError as exc:
        if reached is None or not args.record:
            raise  # the recording could not start: one line, exit 2 (harness.cli)
        # The disk filled up (or the file hit a limit) mid-run: say what the file kept.
        kept = what_was_kept(Path(args.record), *reached)
        print(f"harness serve: error: {exc}; {kept}", file=sys.stderr)
        return 2
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0


def what_was_kept(path: Path, reached: int, dt_ns: int) -> str:
    """What the recording at ``path`` kept of a run that reached step ``reached`` (steps of
    ``dt_ns``) and what was lost, read back from the file the recorder closed after a
    write failed (a full disk: it ends at the last complete flush)."""
    from harness.recording import Recording

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a damaged file is said so below
            recording = Recording(path)
        with recording:
            last, count, complete = recording.last_step, recording.message_count, recording.complete
    except (HarnessError, OSError) as exc:
        return f"recording {path} could not be read back ({exc}): steps 0..{reached} may be lost"
    state = "a valid file" if complete else "a damaged file (open it with --allow-damaged)"
    if count == 0:
        return f"recording {path} is {state} holding no messages; steps 0..{reached} were lost"
    kept = f"recording {path} is {state} keeping steps 0..{last} ({last * dt_ns / 1e9:g} s of "
    kept += f"sim time, {count} messages)"
    if reached <= last:
        return f"{kept}; nothing was lost"
    lost = reached - last
    return f"{kept}; steps {last + 1}..{reached} ({lost * dt_ns / 1e9:g} s of sim time) were lost"
