"""A session's Python calls: commands of joints by name, and the fork edits of a resumed run
(:mod:`harness.resume`): a controller's parameter, a sensor's noise, a free body's pose. Each is
recorded as a ``harness/python`` marker, so a replay applies it where the run did.
:class:`PythonCalls` is a part of :class:`~harness.session.core.SessionCore` (its base), kept
apart so the engine stays the per-step logic."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, cast

import mujoco

from harness.recording import Epoch
from harness.session.core.epochs import reset_epoch
from harness.session.core.markers import MARKER_PYTHON
from harness.session.errors import SessionError
from harness.sim import Notice

if TYPE_CHECKING:
    from harness.session.core.channels import RobotChannels
    from harness.session.core.control import ControlHost
    from harness.sim import Simulation

__all__ = ["PythonCalls"]


class _EpochSink(Protocol):
    def write_epoch(self, epoch: Epoch) -> None: ...


class _Parts(Protocol):
    """What the calls use of the core."""

    sim: Simulation
    control: ControlHost
    sensors: Any
    robots: tuple[RobotChannels, ...]
    recorder: _EpochSink | None
    _epoch: int

    def _marker(self, topic: str, args: Mapping[str, Any]) -> None: ...

    def record_frames(self) -> None: ...

    def _after_state(self, *, record_state: bool = True) -> None: ...

    def notices(self, topic: str, connection: int, notices: Sequence[Notice]) -> None: ...


class PythonCalls:
    """The Python calls of a session core (see the module docstring)."""

    @property
    def _core(self) -> _Parts:
        return cast(_Parts, self)

    def command(
        self,
        joint: str,
        *,
        position: float | None = None,
        velocity: float | None = None,
        effort: float | None = None,
    ) -> list[Notice]:
        """A Python command of one joint by its MuJoCo name (recorded as a ``harness/python``
        marker)."""
        values = {
            "position": None if position is None else float(position),
            "velocity": None if velocity is None else float(velocity),
            "effort": None if effort is None else float(effort),
        }
        self._core._marker(MARKER_PYTHON, {"call": "command", "joint": joint, **values})
        return self._python_command(
            lambda: self._core.sim.command(
                joint,
                position=values["position"],
                velocity=values["velocity"],
                effort=values["effort"],
            ),
            {joint},
        )

    def set_positions(self, positions: Mapping[str, float]) -> list[Notice]:
        """Python position commands by MuJoCo joint names (recorded as a ``harness/python``
        marker)."""
        values = {str(name): float(value) for name, value in positions.items()}
        self._core._marker(MARKER_PYTHON, {"call": "set_positions", "positions": values})
        return self._python_command(lambda: self._core.sim.set_positions(values), set(values))

    def set_parameter(self, controller: str, name: str, value: float) -> None:
        """Change a running controller's parameter (its ``set_parameter``: the JTC's
        ``constraints.*``), recorded as a ``harness/python`` marker (a fork edit of a resumed
        run, :mod:`harness.resume`); :class:`SessionError` naming what is wrong."""
        built = {
            n: c for robot in self._core.control.robots for n, c in robot.manager.built.items()
        }
        found = built.get(controller)
        if found is None:
            raise SessionError(
                f"no controller {controller!r} (controllers: {', '.join(built) or 'none'})"
            )
        setter = getattr(found, "set_parameter", None)
        if setter is None:
            raise SessionError(
                f"controller {controller!r} ({type(found).__name__}) has no parameter that can "
                "change while running"
            )
        try:
            setter(name, float(value))
        except ValueError as exc:
            raise SessionError(str(exc)) from None
        args = {"call": "set_parameter", "controller": controller, "name": name}
        self._core._marker(MARKER_PYTHON, {**args, "value": float(value)})

    def set_sensor_noise(self, sensor: str, stddev: float) -> None:
        """Change a sensor's Gaussian noise ``noise_stddev`` from the next reading on (its
        noise stream stays a function of seed, sensor and step), recorded as a
        ``harness/python`` marker (a fork edit, :mod:`harness.resume`)."""
        sensors = [] if self._core.sensors is None else self._core.sensors.sensors
        found = [s for s in sensors if s.spec.name == sensor]
        if not found:
            names = ", ".join(s.spec.name for s in sensors) or "none"
            raise SessionError(f"no sensor {sensor!r} (sensors: {names})")
        if not (math.isfinite(stddev) and stddev >= 0):
            raise SessionError(f"sensor {sensor!r}: noise stddev must be >= 0, not {stddev!r}")
        for one in found:
            one.spec = dataclasses.replace(one.spec, noise_stddev=float(stddev))
        args = {"call": "set_sensor_noise", "sensor": sensor, "stddev": float(stddev)}
        self._core._marker(MARKER_PYTHON, args)

    def set_body_pose(
        self, body: str, position: Sequence[float], orientation: Sequence[float] | None = None
    ) -> None:
        """Move a free body (a world object, a floating base) to ``position`` and, when
        given, ``orientation`` (quaternion w x y z), at rest, at the current step boundary (a
        fork edit, :mod:`harness.resume`): a discontinuity like a reset, recorded as a
        ``harness/python`` marker and an epoch (reason ``pose``) holding the state the run
        continues from."""
        core = self._core
        sim = core.sim
        model, data = sim.model, sim.data
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
        joint = int(model.body_jntadr[bid]) if bid >= 0 else -1
        if joint < 0 or model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
            raise SessionError(f"body {body!r}: no free body of that name (only one can be moved)")
        pos = [float(v) for v in position]
        quat = None if orientation is None else [float(v) for v in orientation]
        norm = math.sqrt(sum(v * v for v in quat)) if quat is not None else 1.0
        if len(pos) != 3 or (quat is not None and len(quat) != 4) or not norm > 0:
            raise SessionError(f"body {body!r}: a pose is x,y,z or x,y,z,qw,qx,qy,qz")
        if not all(math.isfinite(v) for v in [*pos, *(quat or ())]):
            raise SessionError(f"body {body!r}: the pose must be finite")
        self._core._marker(
            MARKER_PYTHON,
            {"call": "set_body_pose", "body": body, "position": pos, "orientation": quat},
        )
        qadr, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
        data.qpos[qadr : qadr + 3] = pos
        if quat is not None:
            data.qpos[qadr + 3 : qadr + 7] = [v / norm for v in quat]
        data.qvel[dof : dof + 6] = 0.0
        sim.set_state(sim.get_state(), sim.step_index)
        core._epoch += 1
        core.record_frames()
        if core.recorder is not None:
            epoch = reset_epoch(sim, core._epoch)
            core.recorder.write_epoch(epoch._replace(reason="pose"))
        core._after_state(record_state=False)

    def _python_command(self, apply: Callable[[], list[Notice]], joints: set[str]) -> list[Notice]:
        notices = apply()
        for channels in self._core.robots:
            own = [j.removeprefix(channels.prefix) for j in joints if channels.joints.owns(j)]
            if own:
                channels.drop_from_trajectory(own)
        self._core.notices("python", 0, notices)
        return notices
