"""Iteration runners that do not need the Session, for exercising the runner machinery.

- :class:`StepLoadRunner`: real, CPU-bound and deterministic work without a bridge: it steps a
  small MuJoCo arm (two limited hinges under position control sweeping against an obstacle)
  for the scenario's duration and reports joint traces, contact episodes, joint-limit
  summaries and a digest of the state stream. Used by the tests (workers, Dask, reports) and
  by ``bench/bench_runner.py``.
- :class:`ClientRunner`: runs the scenario's client command against a :class:`StandInHost`, a
  tiny real WebSocket endpoint on 127.0.0.1 (the readiness condition: a client connected)
  with an optional MuJoCo stepping thread as its clock. It tests process management: start
  once ready, readiness and wall limits, sim-time limit, stopping with escalation.

Neither is the product's iteration runner: ``harness run`` uses the session-backed one.
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
from dataclasses import dataclass
from types import TracebackType
from typing import Literal

import mujoco
import numpy as np
from websockets.sync.server import ServerConnection, serve

from harness.scenario.client import run_client
from harness.scenario.results import (
    ClientOutcome,
    CollisionSummary,
    IterationResult,
    IterationSpec,
    JointLimitSummary,
    JointTrace,
    Traces,
    judge,
)
from harness.scenario.world import effective_timestep
from harness.sim.contacts import extract_contacts

__all__ = ["ARM_MJCF", "ClientRunner", "StandInHost", "StepLoadRunner"]

ARM_MJCF = """
<mujoco model="standin_arm">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="obstacle" pos="0.55 0 0.2">
      <geom name="obstacle" type="box" size="0.05 0.05 0.05"/>
    </body>
    <body name="base" pos="0 0 0.1">
      <geom name="base" type="cylinder" size="0.05 0.05"/>
      <body name="upper_arm" pos="0 0 0.1">
        <joint name="shoulder" type="hinge" axis="0 1 0" range="-1.2 1.2" limited="true"
               damping="0.5"/>
        <geom name="upper_arm" type="capsule" fromto="0 0 0 0 0 0.3" size="0.03" mass="1"/>
        <body name="forearm" pos="0 0 0.3">
          <joint name="elbow" type="hinge" axis="0 1 0" range="-2 2" limited="true"
                 damping="0.2"/>
          <geom name="forearm" type="capsule" fromto="0 0 0 0.3 0 0" size="0.025" mass="0.5"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="shoulder" joint="shoulder" kp="60" kv="4"/>
    <position name="elbow" joint="elbow" kp="20" kv="1"/>
  </actuator>
</mujoco>
"""


_DEBOUNCE = 0.02


def _command(t: float) -> tuple[float, float]:
    """Shoulder sweeps to 1.3 rad (beyond its 1.2 limit), elbow lifts the forearm into the
    obstacle once per period."""
    return 1.3 * math.sin(2.0 * math.pi * 0.5 * t), -0.6 + 0.5 * math.sin(2.0 * math.pi * 0.25 * t)


@dataclass(frozen=True)
class StepLoadRunner:
    """Steps :data:`ARM_MJCF` for the spec's sim-time limit (at most ``max_steps``) and
    samples traces ``samples`` times; deterministic for a given spec."""

    max_steps: int | None = None
    samples: int = 400

    def __call__(self, spec: IterationSpec) -> IterationResult:
        start = time.monotonic()
        model = mujoco.MjModel.from_xml_string(ARM_MJCF)
        model.opt.timestep = effective_timestep(spec.scenario)
        data = mujoco.MjData(model)
        steps = max(1, round(spec.sim_time_limit / model.opt.timestep))
        if self.max_steps is not None:
            steps = min(steps, self.max_steps)
        every = max(1, steps // self.samples)
        names = [model.joint(j).name for j in range(model.njnt)]
        digest = hashlib.sha256()
        state = np.zeros(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION))
        times: list[float] = []
        pos: list[list[float]] = [[] for _ in names]
        vel: list[list[float]] = [[] for _ in names]
        cmd: list[list[float]] = [[] for _ in names]
        lo = model.jnt_range[:, 0].copy()
        hi = model.jnt_range[:, 1].copy()
        qmin = np.full(model.njnt, np.inf)
        qmax = np.full(model.njnt, -np.inf)
        excess = np.zeros(model.njnt)
        violations = np.zeros(model.njnt, dtype=np.int64)
        open_pairs: dict[tuple[int, int], list[float]] = {}
        episodes: list[CollisionSummary] = []
        for k in range(steps):
            t = k * model.opt.timestep
            data.ctrl[:] = _command(t)
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            digest.update(state.tobytes())
            q = data.qpos[: model.njnt]
            np.minimum(qmin, q, out=qmin)
            np.maximum(qmax, q, out=qmax)
            beyond = np.maximum(lo - q, q - hi)
            violations += beyond > 0
            np.maximum(excess, beyond, out=excess)
            self._contacts(model, data, t, open_pairs, episodes)
            if k % every == 0:
                times.append(data.time)
                for j in range(model.njnt):
                    pos[j].append(float(data.qpos[j]))
                    vel[j].append(float(data.qvel[j]))
                    cmd[j].append(float(data.ctrl[j]))
        end_time = steps * model.opt.timestep
        for (b1, b2), (begin, depth, force, _last) in sorted(open_pairs.items()):
            episodes.append(
                CollisionSummary(
                    model.body(b1).name, model.body(b2).name, begin, None, depth, force
                )
            )
        episodes.sort(key=lambda c: (c.begin, c.body1, c.body2))
        limits = tuple(
            JointLimitSummary(
                names[j],
                float(lo[j]),
                float(hi[j]),
                float(qmin[j]),
                float(qmax[j]),
                float(excess[j]),
                int(violations[j]),
            )
            for j in range(model.njnt)
        )
        traces = Traces(
            time=tuple(times),
            joints=tuple(
                JointTrace(
                    names[j],
                    tuple(pos[j]),
                    tuple(vel[j]),
                    tuple(cmd[j]),
                    float(lo[j]),
                    float(hi[j]),
                    None,
                )
                for j in range(model.njnt)
            ),
        )
        return IterationResult(
            simulation=spec.simulation,
            iteration=spec.iteration,
            verdicts=judge(spec.scenario.criteria, None, episodes, limits),
            sim_time=end_time,
            steps=steps,
            collisions=tuple(episodes),
            joint_limits=limits,
            traces=traces,
            state_digest=digest.hexdigest(),
            wall_seconds=time.monotonic() - start,
        )

    @staticmethod
    def _contacts(
        model: mujoco.MjModel,
        data: mujoco.MjData,
        t: float,
        open_pairs: dict[tuple[int, int], list[float]],
        episodes: list[CollisionSummary],
    ) -> None:
        contacts = extract_contacts(model, data)
        seen: dict[tuple[int, int], tuple[float, float]] = {}
        for i in range(contacts.size):
            if contacts.depth[i] <= 0:
                continue
            b1, b2 = sorted((int(contacts.body1[i]), int(contacts.body2[i])))
            d, f = seen.get((b1, b2), (0.0, 0.0))
            seen[(b1, b2)] = (
                max(d, float(contacts.depth[i])),
                max(f, float(contacts.normal_force[i])),
            )
        for pair, (depth, force) in seen.items():
            episode = open_pairs.setdefault(pair, [t, 0.0, 0.0, t])
            episode[1] = max(episode[1], depth)
            episode[2] = max(episode[2], force)
            episode[3] = t
        # An episode ends after _DEBOUNCE seconds without contact (no chatter on grazing).
        for pair in [p for p, e in open_pairs.items() if p not in seen and t - e[3] > _DEBOUNCE]:
            begin, depth, force, last = open_pairs.pop(pair)
            episodes.append(
                CollisionSummary(
                    model.body(pair[0]).name, model.body(pair[1]).name, begin, last, depth, force
                )
            )


class StandInHost:
    """A real WebSocket endpoint on ``host``:0 that records whether a client connected, and
    a clock: ``lockstep`` (sim time stays 0: nothing steps it) or ``fast`` (once a client
    connected, a thread steps :data:`ARM_MJCF` until ``sim_time_limit``). A context manager;
    leaves nothing running."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        clock: Literal["lockstep", "fast"] = "lockstep",
        sim_time_limit: float = math.inf,
    ) -> None:
        self._connected = threading.Event()
        self._stop = threading.Event()
        self._server = serve(self._handle, host, 0)
        self.port: int = self._server.socket.getsockname()[1]
        self._host = host
        self._sim_time = 0.0
        self._clock = clock
        self._limit = sim_time_limit
        self._threads = [threading.Thread(target=self._server.serve_forever, daemon=True)]
        if clock == "fast":
            self._threads.append(threading.Thread(target=self._step, daemon=True))

    @property
    def url(self) -> str:
        """``ws://host:port`` of the endpoint."""
        return f"ws://{self._host}:{self.port}"

    def client_connected(self) -> bool:
        """True once a client connected."""
        return self._connected.is_set()

    def sim_time(self) -> float:
        """Simulation seconds stepped so far."""
        return self._sim_time

    def _handle(self, connection: ServerConnection) -> None:
        self._connected.set()
        for _message in connection:
            if self._stop.is_set():
                break

    def _step(self) -> None:
        # The clock starts when the client is ready, as a session's would.
        while not self._connected.wait(0.05):
            if self._stop.is_set():
                return
        model = mujoco.MjModel.from_xml_string(ARM_MJCF)
        data = mujoco.MjData(model)
        while not self._stop.is_set() and data.time < self._limit:
            data.ctrl[:] = _command(data.time)
            mujoco.mj_step(model, data)
            self._sim_time = data.time

    def __enter__(self) -> StandInHost:
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._stop.set()
        self._server.shutdown()
        for thread in self._threads:
            thread.join(timeout=10.0)


@dataclass(frozen=True)
class ClientRunner:
    """Runs the spec's client against a :class:`StandInHost` with the given clock."""

    clock: Literal["lockstep", "fast"] = "lockstep"
    grace: float = 3.0

    def __call__(self, spec: IterationSpec) -> IterationResult:
        start = time.monotonic()
        with StandInHost(spec.host, self.clock, spec.sim_time_limit) as host:
            if spec.client is None:
                outcome = ClientOutcome("no_client", None, "no client command")
            else:
                outcome = run_client(
                    spec.client, host, spec.sim_time_limit, spec.out_dir / "client.log", self.grace
                )
            sim_time = host.sim_time()
            port = host.port
        return IterationResult(
            simulation=spec.simulation,
            iteration=spec.iteration,
            verdicts=judge(spec.scenario.criteria, outcome, (), ()),
            sim_time=sim_time,
            steps=round(sim_time / effective_timestep(spec.scenario)),
            client=outcome,
            port=port,
            wall_seconds=time.monotonic() - start,
        )
