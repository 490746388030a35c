"""``harness replay --actuation kinematic|servo`` for a mobile base: re-run a recording's
``/cmd_vel`` stream with the planar (kinematic) base or the wheeled diff drive (servo) base
and measure how the base's path differs.

The recorded base controller (a ``diff_drive_controller/DiffDriveController`` or a
``planar_controller/PlanarController`` in the recording's controllers configuration) names the
command topic. ``kinematic`` re-runs with a planar controller taking the recorded controller's
topic, message type, timeout and ``linear.x``/``angular.z`` limits; ``servo`` needs the
wheels, so a recorded diff drive (a planar recording has no wheel geometry and is refused).
The re-run drives a fresh :class:`~harness.session.SessionCore` of the robot rebuilt from
the recording's sources, as :mod:`harness.replay.pipeline` does (no socket, thread or file):
every recorded incoming ``publish`` frame on the command topic is applied at the step
boundary it was recorded at, by one connection of the core's bridge, and the base's free
joint pose is compared step by step with the recorded physics states: path deviation (the
largest and mean planar distance between the two bases at the same step), final pose error
(distance and heading), and each path's length.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.controllers.config import ControllersConfig, ControllerSpec
from harness.controllers.diff_drive import TYPE_DIFF_DRIVE
from harness.controllers.planar import TYPE_PLANAR
from harness.models import LoadedRobot, LoadedWorld
from harness.replay.base_checks import contact_pairs, encoder_distance, robot_bodies
from harness.replay.errors import LevelUnavailableError
from harness.replay.resim import parse_actuation
from harness.replay.source import open_recording, read_states, rebuild_run
from harness.vocabulary import Actuation

__all__ = ["BaseResimReport", "base_controller", "is_base_recording", "resimulate_base"]

F64 = npt.NDArray[np.float64]
_COPIED = (
    "cmd_vel_topic", "use_stamped_vel", "cmd_vel_timeout", "odom_topic", "publish_rate",
    "odom_frame_id", "base_frame_id", "enable_odom_tf", "linear", "angular",
    "linear.x.max_velocity", "linear.x.min_velocity", "linear.x.max_acceleration",
    "linear.x.max_deceleration", "angular.z.max_velocity", "angular.z.min_velocity",
    "angular.z.max_acceleration", "angular.z.max_deceleration",
)  # fmt: skip


@dataclass(frozen=True)
class BaseResimReport:
    """How the re-run base's path differs from the recorded one (metres, radians)."""

    path: str
    actuation: Actuation
    recorded_controller: str
    command_topic: str
    commands: int
    steps_compared: int
    max_path_deviation: float
    mean_path_deviation: float
    final_position_error: float
    final_heading_error: float
    recorded_path_length: float
    resimulated_path_length: float
    recorded_encoder_distance: float | None = None
    resimulated_encoder_distance: float | None = None
    collisions_appearing: tuple[tuple[str, str], ...] = ()
    collisions_disappearing: tuple[tuple[str, str], ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The report as plain JSON values."""
        return asdict(self)

    def format(self) -> str:
        """A short text report."""
        return "\n".join(
            [
                f"{self.path}: base re-run ({self.actuation}) of {self.commands} commands on "
                f"{self.command_topic} (recorded with {self.recorded_controller})",
                f"  steps compared        {self.steps_compared}",
                f"  path deviation        max {self.max_path_deviation:.4f} m, "
                f"mean {self.mean_path_deviation:.4f} m",
                f"  final pose error      {self.final_position_error:.4f} m, "
                f"{math.degrees(self.final_heading_error):.2f} deg",
                f"  path length           recorded {self.recorded_path_length:.4f} m, "
                f"re-run {self.resimulated_path_length:.4f} m",
                *self._slip_lines(),
                "  collisions            "
                + (
                    "same in both runs"
                    if not self.collisions_appearing and not self.collisions_disappearing
                    else f"appearing {_pairs(self.collisions_appearing)}; "
                    f"disappearing {_pairs(self.collisions_disappearing)}"
                ),
            ]
        )

    def _slip_lines(self) -> list[str]:
        lines = []
        for run, encoder, truth in (
            ("recorded", self.recorded_encoder_distance, self.recorded_path_length),
            ("re-run", self.resimulated_encoder_distance, self.resimulated_path_length),
        ):
            if encoder is not None:
                lines.append(
                    f"  wheel slip ({run})".ljust(24) + f"encoders {encoder:.4f} m vs ground "
                    f"truth {truth:.4f} m (slip {encoder - truth:+.4f} m)"
                )
        return lines


def _pairs(pairs: tuple[tuple[str, str], ...]) -> str:
    return ", ".join(f"{a} - {b}" for a, b in pairs) or "none"


def base_controller(config: ControllersConfig | str) -> ControllerSpec | None:
    """The recorded run's base controller (diff drive or planar), if any."""
    if isinstance(config, str):
        return None
    for spec in config.controllers:
        if spec.type in (TYPE_DIFF_DRIVE, TYPE_PLANAR):
            return spec
    return None


def _topic(spec: ControllerSpec) -> str:
    name = str(spec.params.get("cmd_vel_topic", "~/cmd_vel"))
    return f"/{spec.name}/" + name.removeprefix("~/") if name.startswith("~/") else name


def _free_joint(model: mujoco.MjModel, spec: ControllerSpec) -> tuple[str, int]:
    free = {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or "": j
        for j in range(model.njnt)
        if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)
    }
    wanted = str(spec.params.get("base_joint", f"{spec.params.get('base_frame_id', 'base_link')}"
                                 "::__free__"))  # fmt: skip
    if wanted in free:
        return wanted, int(model.jnt_qposadr[free[wanted]])
    robots = [name for name in free if name.count("::") == 1]  # world models: model::link::
    if len(robots) == 1:
        return robots[0], int(model.jnt_qposadr[free[robots[0]]])
    raise LevelUnavailableError(
        f"no floating base for controller {spec.name!r}: free joints {sorted(free)}"
    )


def _alternate(spec: ControllerSpec, actuation: Actuation, base_joint: str) -> ControllerSpec:
    if actuation is Actuation.SERVO:
        if spec.type != TYPE_DIFF_DRIVE:
            raise LevelUnavailableError(
                f"controller {spec.name!r} is a planar base: --actuation servo needs a diff drive "
                "(its wheels), which the recording does not have"
            )
        return spec
    params: dict[str, Any] = {k: v for k, v in spec.params.items() if k in _COPIED}
    params["base_joint"] = base_joint
    if spec.type == TYPE_DIFF_DRIVE:
        params.setdefault("use_stamped_vel", True)  # diff drive's default, kept
    return ControllerSpec(spec.name, TYPE_PLANAR, params)


def _poses(model: mujoco.MjModel, qpos: F64, adr: int) -> F64:
    """(N, 3): x, y, heading of the free joint at ``adr`` in each row of ``qpos``."""
    xy = qpos[:, adr : adr + 2]
    w, x, y, z = (qpos[:, adr + 3 + i] for i in range(4))
    heading = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.column_stack([xy, heading])


def _rerun(
    robot: LoadedRobot,
    controllers: ControllersConfig,
    topic: str,
    msg_type: str,
    frames: Sequence[tuple[int, Mapping[str, Any]]],
    last: int,
    where: str,
) -> F64:
    """The re-run: a fresh :class:`~harness.session.SessionCore` of ``robot`` with
    ``controllers`` (no sockets, threads or files), each recorded command published on
    ``topic`` as ``msg_type`` by one connection at the step boundary it was recorded at
    (``step - 1``; advertised before the first), stepped up to ``last`` (or the last command).
    Returns every step's ``qpos`` (row ``k``: after step ``k``). A step that fails ends the
    re-run with :class:`LevelUnavailableError` naming it (and ``where``, the recording)."""
    from harness.session.core import CoreOptions, SessionCore

    core = SessionCore(robot, CoreOptions(controllers=controllers))
    bridge = core.bridge
    assert bridge is not None
    sim = core.sim
    rows = []
    try:
        core.start()
        core.publish_initial()
        rows.append(sim.data.qpos.copy())
        connection = bridge.connect()
        advertise = {"op": "advertise", "topic": topic, "type": msg_type, "id": "base-rerun"}

        def advance_to(target: int) -> None:
            while sim.step_index < target:
                try:
                    core.advance()
                except Exception as exc:
                    raise LevelUnavailableError(
                        f"{where}: the base re-run failed at step {sim.step_index}: "
                        f"{type(exc).__name__}: {exc}"
                    ) from None
                bridge.drain()
                rows.append(sim.data.qpos.copy())

        for i, (step, msg) in enumerate(frames):
            advance_to(step - 1)
            publish = {"op": "publish", "topic": topic, "msg": dict(msg)}
            for frame in (advertise, publish) if i == 0 else (publish,):
                bridge.receive(connection, json.dumps(frame), sim.sim_time_ns)
            bridge.drain()
        advance_to(last)
    finally:
        core.finish()
    return np.stack(rows)


def resimulate_base(
    path: str | Path, actuation: Actuation | str, *, allow_damaged: bool = False
) -> BaseResimReport:
    """Re-run the recording's base commands with ``actuation`` (``kinematic``: a planar
    base; ``servo``: the diff drive; see the module docstring)."""
    mode = parse_actuation(actuation)
    from harness.session.core import controllers_from_metadata

    rec = open_recording(path, allow_damaged=allow_damaged)
    try:
        config = controllers_from_metadata(rec.metadata.get("controllers"))
        spec = base_controller(config)
        if spec is None or isinstance(config, str):
            raise LevelUnavailableError(
                f"{path}: no base controller (diff drive or planar) in the recording"
            )
        robot = rebuild_run(rec)
        if isinstance(robot, LoadedWorld):
            raise LevelUnavailableError(
                f"{path}: a world of several robots: base re-runs take one robot"
            )
        joint, adr = _free_joint(robot.model, spec)
        topic = _topic(spec)
        frames = [
            (f.step, json.loads(f.text).get("msg", {}))
            for f in rec.bridge_frames()
            if f.direction == 0 and f.op == "publish" and f.topic == topic and not f.binary
        ]
        recorded = read_states(rec)
        msg_type = (
            "geometry_msgs/msg/TwistStamped"
            if spec.params.get("use_stamped_vel", True)
            else "geometry_msgs/msg/Twist"
        )
    finally:
        rec.close()
    alternate = _alternate(spec, mode, joint)
    controllers = replace(
        config,
        controllers=tuple(alternate if c is spec else c for c in config.controllers),
    )
    rerun = _rerun(robot, controllers, topic, msg_type, frames, int(recorded.steps[-1]), str(path))
    steps = np.arange(rerun.shape[0], dtype=np.int64)
    common, ia, ib = np.intersect1d(recorded.steps, steps, return_indices=True)
    a = _poses(robot.model, recorded.qpos[ia], adr)
    b = _poses(robot.model, rerun[ib], adr)
    if not common.size:
        raise LevelUnavailableError(f"{path}: the re-run shares no step with the recording")
    deviation = np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])
    heading = float(b[-1, 2] - a[-1, 2])
    heading = math.atan2(math.sin(heading), math.cos(heading))

    def length(p: F64) -> float:
        return float(np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1])).sum())

    wheels = [
        str(w)
        for key in ("left_wheel_names", "right_wheel_names")
        for w in spec.params.get(key, []) or []
    ]
    radius = float(spec.params.get("wheel_radius", 0.0) or 0.0)
    slip = wheels and radius > 0 and spec.type == TYPE_DIFF_DRIVE
    bodies = robot_bodies(robot.model, joint)
    before = contact_pairs(robot.model, recorded.qpos[ia], bodies)
    after = contact_pairs(robot.model, rerun[ib], bodies)

    return BaseResimReport(
        path=str(path),
        actuation=mode,
        recorded_controller=spec.type,
        command_topic=topic,
        commands=len(frames),
        steps_compared=int(common.size),
        max_path_deviation=float(deviation.max()),
        mean_path_deviation=float(deviation.mean()),
        final_position_error=float(deviation[-1]),
        final_heading_error=abs(heading),
        recorded_path_length=length(a),
        resimulated_path_length=length(b),
        recorded_encoder_distance=(
            encoder_distance(robot.model, recorded.qpos[ia], wheels, radius) if slip else None
        ),
        resimulated_encoder_distance=(
            encoder_distance(robot.model, rerun[ib], wheels, radius) if slip else None
        ),
        collisions_appearing=tuple(sorted(after - before)),
        collisions_disappearing=tuple(sorted(before - after)),
    )


def is_base_recording(path: str | Path) -> bool:
    """Whether the recording's run had a base controller (``--actuation`` then re-runs the base)."""
    from harness.session.core import controllers_from_metadata

    rec = open_recording(path, allow_damaged=True)
    try:
        return (
            base_controller(controllers_from_metadata(rec.metadata.get("controllers"))) is not None
        )
    finally:
        rec.close()
