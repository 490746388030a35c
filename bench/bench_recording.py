"""Recording cost: our writer vs the MCAP container alone, and a stepping loop with and
without full recording.

1. messages/s of ``Recorder.write_physics_state`` (hand-laid CDR + the recorder's ChunkWriter,
   zstd on the writer's thread, chunk and data CRCs) vs ``mcap.Writer`` fed the same messages
   pre-serialised (the pure-Python container's speed).
2. steps/s of a raw ``mj_step`` loop on a 7-joint arm + gripper on a table with a box, with full
   recording (mj_getState + state every step, a bridge frame per step, /joint_states, /clock
   and a JSON bridge frame at 100 Hz) vs the same loop without recording: reported, to show
   where the time goes (issue 5's target, >= 0.5 for a lockstep session with recording vs
   without, is measured in bench_session.py).
   The breakdown row says where the time goes.
3. a bare ``harness.sim.Simulation`` loop (issue 20's target, >= 0.6) recording what a
   session records of a run without clients, through the product's path: every state (read
   into one buffer), ``/joint_states``, ``/tf`` and ``/clock`` at 100 Hz (CDR laid out once:
   ``harness.recording.templates``); then the same with a lockstep client's bridge frames
   (reported). Their notes give the ratio with a recorder that writes nothing: the ceiling set
   by the loop's own recording inputs (the state read, the records, the messages' bytes).
"""

from __future__ import annotations

import json
import tempfile
import time
from functools import partial
from pathlib import Path

import mujoco
import numpy as np
from common import Row, best_of
from mcap.writer import CompressionType, Writer

from harness.recording import BridgeFrame, PhysicsState, Recorder
from harness.recording.layout import TYPE_PHYSICS_STATE, channel_metadata, schema_text, typestore
from harness.recording.stateslot import PhysicsStateSlot
from harness.sim.state import qpos_qvel_slices

SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
METADATA = {
    "timestep": "0.001",
    "integrator": "IMPLICITFAST",
    "seed": "0",
    "model_sha256": "0" * 64,
    "control_modes": "{}",
}


def _arm_xml() -> str:
    """A Panda-sized arm: 7 hinges, 2 finger slides, position servos, table and a box."""
    axes = ["0 0 1", "0 1 0", "0 0 1", "0 -1 0", "0 0 1", "0 -1 0", "0 0 1"]
    body = (
        '<body name="hand" pos="0 0 0.1"><geom type="box" size="0.02 0.08 0.02"/>'
        '<body name="finger_l" pos="0 0.04 0.05"><joint name="f1" type="slide" axis="0 1 0" '
        'range="0 0.04"/><geom type="box" size="0.01 0.01 0.03"/></body>'
        '<body name="finger_r" pos="0 -0.04 0.05"><joint name="f2" type="slide" axis="0 -1 0" '
        'range="0 0.04"/><geom type="box" size="0.01 0.01 0.03"/></body></body>'
    )
    for i in reversed(range(7)):
        body = (
            f'<body name="link{i}" pos="0 0 {0.05 if i == 0 else 0.12}">'
            f'<joint name="j{i}" axis="{axes[i]}" range="-2.8 2.8" damping="1"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 0.12" size="0.04"/>{body}</body>'
        )
    actuators = (
        "".join(f'<position joint="j{i}" kp="500" dampratio="1"/>' for i in range(7))
        + '<position joint="f1" kp="100" dampratio="1"/>'
        + '<position joint="f2" kp="100" dampratio="1"/>'
    )
    return (
        '<mujoco><option timestep="0.001" integrator="implicitfast"/><worldbody>'
        '<geom type="plane" size="2 2 0.1"/>'
        '<body pos="0.5 0 0.2"><geom type="box" size="0.3 0.3 0.02"/></body>'
        '<body pos="0.5 0.1 0.26"><freejoint/><geom type="box" size="0.03 0.03 0.03" '
        f'mass="0.2"/></body>{body}</worldbody><actuator>{actuators}</actuator></mujoco>'
    )


def _writer_rows(quick: bool, tmp: Path) -> list[Row]:
    n = 5_000 if quick else 30_000
    rng = np.random.default_rng(0)
    state, qpos, qvel = rng.random(100), rng.random(16), rng.random(15)

    def ours() -> None:
        with Recorder(tmp / "ours.mcap", metadata=METADATA) as rec:
            for k in range(n):
                rec.write_physics_state(PhysicsState(
                    step=k, sim_time_ns=k * 1_000_000, state_spec=SPEC, state=state,
                    qpos=qpos, qvel=qvel,
                ))  # fmt: skip

    store = typestore()
    cls = store.types[TYPE_PHYSICS_STATE]
    payloads = [
        bytes(
            store.serialize_cdr(
                cls(step=k, sim_time_ns=k * 1_000_000, state_spec=SPEC, state=state,
                    qpos=qpos, qvel=qvel),
                TYPE_PHYSICS_STATE,
            )
        )
        for k in range(n)
    ]  # fmt: skip

    def container() -> None:
        with open(tmp / "limit.mcap", "wb") as f:
            writer = Writer(f, compression=CompressionType.ZSTD, enable_data_crcs=True)
            writer.start(profile="ros2")
            schema = writer.register_schema(
                TYPE_PHYSICS_STATE, "ros2msg", schema_text(TYPE_PHYSICS_STATE)
            )
            channel = writer.register_channel(
                "/harness/state", "cdr", schema, channel_metadata(TYPE_PHYSICS_STATE)
            )
            for k, data in enumerate(payloads):
                writer.add_message(channel, k * 1_000_000, data, k * 1_000_000, k)
            writer.finish()

    t_ours = best_of(ours, 3)
    t_limit = best_of(container, 3)
    ratio = t_limit / t_ours
    return [
        Row(
            "recording: writer msg/s vs mcap.Writer (pre-serialised CDR)",
            n / t_ours,
            n / t_limit,
            "msg/s",
            "report (container is the ceiling)",
            True,
            note=f"PhysicsState with 131 float64; ours is {ratio:.2f} of the container",
        )
    ]


class _NullRecorder:
    """Takes the loop's records and writes nothing (the ceiling of any recorder)."""

    def write_physics_state(self, record: PhysicsState) -> None:
        pass

    def physics_state_slot(
        self, state_spec: int, state_size: int, qpos: slice, qvel: slice
    ) -> PhysicsStateSlot:
        return PhysicsStateSlot(np.zeros(state_size), lambda step, sim_time_ns: None)

    def write_bridge_frame(self, frame: BridgeFrame) -> None:
        pass

    def write_message(self, topic: str, msgtype: str, msg: object, *, sim_time_ns: int) -> None:
        pass


def _loop(
    model: mujoco.MjModel,
    steps: int,
    recorder: Recorder | _NullRecorder | None,
) -> float:
    data = mujoco.MjData(model)
    state = np.zeros(mujoco.mj_stateSize(model, SPEC))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(1, model.njnt)]
    targets = np.sin(np.arange(model.nu, dtype=np.float64))
    start = time.perf_counter()
    for k in range(steps):
        data.ctrl[:] = targets * np.sin(k * 1e-3)
        mujoco.mj_step(model, data)
        if recorder is None:
            continue
        t = (k + 1) * 1_000_000
        mujoco.mj_getState(model, data, state, SPEC)
        # built as the session core builds it (positionally)
        recorder.write_physics_state(PhysicsState(k + 1, t, SPEC, state, data.qpos, data.qvel))
        recorder.write_bridge_frame(BridgeFrame(
            step=k + 1, sim_time_ns=t, direction=0, connection=1, seq=k, op="call_service",
            topic="/harness/step", text='{"op":"call_service","service":"/harness/step"}',
        ))  # fmt: skip
        if k % 10 == 0:
            sec, nanosec = divmod(t, 1_000_000_000)
            js = {
                "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
                "name": names,
                "position": data.qpos[7:].tolist(),
                "velocity": data.qvel[6:].tolist(),
                "effort": data.actuator_force.tolist(),
            }
            recorder.write_message("/joint_states", "sensor_msgs/msg/JointState", js, sim_time_ns=t)
            recorder.write_message(
                "/clock", "rosgraph_msgs/msg/Clock", {"clock": js["header"]["stamp"]}, sim_time_ns=t
            )
            recorder.write_bridge_frame(BridgeFrame(
                step=k + 1, sim_time_ns=t, direction=1, connection=1, seq=k, op="publish",
                topic="/joint_states",
                text=json.dumps({"op": "publish", "topic": "/joint_states", "msg": js}),
            ))  # fmt: skip
    return time.perf_counter() - start


def _index(addresses: list[int]) -> slice | np.ndarray:
    first = addresses[0]
    if addresses == list(range(first, first + len(addresses))):
        return slice(first, first + len(addresses))
    return np.array(addresses)


class _SimLoop:
    """A bare ``Simulation`` loop recording what a session records of a run without clients,
    through the product's recording path: the state after every step (read into one buffer),
    ``/joint_states``, ``/tf`` and ``/clock`` at 100 Hz (CDR laid out once per run:
    :mod:`harness.recording.templates`). ``frames``: also a bridge frame per step (a
    ``/harness/step`` call) and the JSON text of a ``/joint_states`` publish at 100 Hz."""

    def __init__(self, path: Path) -> None:
        from harness.models import load_robot
        from harness.recording.templates import JointStateCdr
        from harness.session.core.tf import RobotFrames, TfTree

        self.robot = load_robot(path, control="position")
        model = self.robot.model
        self.names = [f"j{i}" for i in range(7)] + ["f1", "f2"]
        joints = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in self.names]
        # consecutive joints read as slices (views), as the session's joint_state_arrays does
        self.qadr = _index([int(model.jnt_qposadr[j]) for j in joints])
        self.dadr = _index([int(model.jnt_dofadr[j]) for j in joints])
        self.js = JointStateCdr(self.names)
        self.tree = TfTree(model, [RobotFrames(self.robot.description)])
        self.every = round(0.01 / model.opt.timestep)  # 100 Hz

    def run(self, steps: int, recorder: Recorder | _NullRecorder | None, frames: bool) -> float:
        from harness.recording.templates import clock_cdr
        from harness.sim import Simulation

        sim = Simulation(self.robot)
        data = sim.data
        qpos, qvel = data.qpos, data.qvel
        slot = None
        if recorder is not None:
            slot = recorder.physics_state_slot(SPEC, sim.state_size, *qpos_qvel_slices(sim.model))
        js, tree, qadr, dadr, every = self.js, self.tree, self.qadr, self.dadr, self.every
        sim.set_positions({n: 0.02 * np.sin(i) for i, n in enumerate(self.names)})
        start = time.perf_counter()
        for k in range(1, steps + 1):
            sim.step()
            if recorder is None or slot is None:
                continue
            t = k * 1_000_000
            sim.get_state(slot.state)
            slot.write(k, t)
            if frames:
                recorder.write_bridge_frame(BridgeFrame(
                    step=k, sim_time_ns=t, direction=0, connection=1, seq=k, op="call_service",
                    topic="/harness/step", text='{"op":"call_service","service":"/harness/step"}',
                ))  # fmt: skip
            if k % every == 0:
                position, velocity = qpos[qadr], qvel[dadr]
                effort = data.qfrc_actuator[dadr]
                recorder.write_message(
                    "/joint_states", "sensor_msgs/msg/JointState",
                    js.encode(t, position, velocity, effort), sim_time_ns=t,
                )  # fmt: skip
                recorder.write_message(
                    "/tf", "tf2_msgs/msg/TFMessage",
                    tree.moving_record(partial(tree.moving_poses, qpos, sim.body_poses), t),
                    sim_time_ns=t,
                )  # fmt: skip
                recorder.write_message(
                    "/clock", "rosgraph_msgs/msg/Clock", clock_cdr(t), sim_time_ns=t
                )
                if frames:
                    sec, nanosec = divmod(t, 1_000_000_000)
                    msg = {
                        "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
                        "name": self.names,
                        "position": position.tolist(),
                        "velocity": velocity.tolist(),
                        "effort": effort.tolist(),
                    }
                    recorder.write_bridge_frame(BridgeFrame(
                        step=k, sim_time_ns=t, direction=1, connection=1, seq=k, op="publish",
                        topic="/joint_states",
                        text=json.dumps({"op": "publish", "topic": "/joint_states", "msg": msg}),
                    ))  # fmt: skip
        return time.perf_counter() - start


def _sim_row(quick: bool, tmp: Path) -> list[Row]:
    """Issue 20's row: a bare ``Simulation`` loop with full recording vs without."""
    arm = tmp / "arm.xml"
    arm.write_text(_arm_xml())
    loop = _SimLoop(arm)
    steps = 3_000 if quick else 20_000
    rows = []
    for frames in (False, True):
        # interleaved, best of five each: a machine slowing down for a while then costs
        # every variant alike instead of the one measured then
        bares, fulls, ceilings = [], [], []
        for i in range(5):
            bares.append(loop.run(steps, None, frames))
            with Recorder(tmp / f"sim{i}.mcap", metadata=METADATA) as rec:
                fulls.append(loop.run(steps, rec, frames))
            ceilings.append(loop.run(steps, _NullRecorder(), frames))
        bare, full, ceiling = min(bares), min(fulls), min(ceilings)
        note = (
            f"Simulation.step {bare / steps * 1e6:.1f} us/step bare; "
            f"{(full - bare) / steps * 1e6:.1f} us/step recording, of which "
            f"{(ceiling - bare) / steps * 1e6:.1f} us the loop's own record building "
            f"(a recorder writing nothing: ratio {bare / ceiling:.2f})"
        )
        if not frames:
            rows.append(Row(
                "recording: bare Simulation loop, full recording vs none",
                steps / full, steps / bare, "st/s", "ratio >= 0.6", bare / full >= 0.6,
                note=note + f"; every state, /joint_states, /tf ({len(loop.tree.moving)} "
                "transforms), /clock at 100 Hz",
            ))  # fmt: skip
        else:
            rows.append(Row(
                "recording: the same loop + a bridge frame per step and a JSON publish at 100 Hz",
                steps / full, steps / bare, "st/s", "report", True,
                note=note + "; what a lockstep client's frames add (with their JSON text)",
            ))  # fmt: skip
    return rows


def _loop_rows(quick: bool, tmp: Path) -> list[Row]:
    model = mujoco.MjModel.from_xml_string(_arm_xml())
    steps = 3_000 if quick else 20_000
    bare = min(_loop(model, steps, None) for _ in range(3))
    recorded = []
    for i in range(3):
        with Recorder(tmp / f"loop{i}.mcap", metadata=METADATA) as rec:
            recorded.append(_loop(model, steps, rec))
        stats = rec.stats
    full = min(recorded)
    # Where the time goes: each recording part timed alone.
    data = mujoco.MjData(model)
    state = np.zeros(mujoco.mj_stateSize(model, SPEC))
    n = 2_000
    with Recorder(tmp / "parts.mcap", metadata=METADATA) as rec:
        t_get = best_of(lambda: [mujoco.mj_getState(model, data, state, SPEC) for _ in range(n)], 3)
        t_state = best_of(
            lambda: [
                rec.write_physics_state(PhysicsState(
                    step=0, sim_time_ns=0, state_spec=SPEC, state=state, qpos=data.qpos,
                    qvel=data.qvel,
                )) for _ in range(n)
            ], 3,
        )  # fmt: skip
        t_frame = best_of(
            lambda: [
                rec.write_bridge_frame(BridgeFrame(
                    step=0, sim_time_ns=0, direction=0, connection=1, seq=0, op="x",
                    topic="", text="{}",
                )) for _ in range(n)
            ], 3,
        )  # fmt: skip
    step_us = bare / steps * 1e6
    rest_us = (full - bare) / steps * 1e6 - (t_get + t_state + t_frame) / n * 1e6
    note = (
        f"per step: mj_step {step_us:.1f} us, mj_getState {t_get / n * 1e6:.1f} us, "
        f"state msg {t_state / n * 1e6:.1f} us, bridge frame {t_frame / n * 1e6:.1f} us, "
        f"100 Hz JointState+Clock+frame and rest {rest_us:.1f} us; "
        f"flushes {stats.flushes}, longest {stats.flush_seconds_max * 1e3:.1f} ms"
    )
    return [
        Row(
            "recording: raw mj_step loop, full recording vs none",
            steps / full,
            steps / bare,
            "st/s",
            "report (where the time goes)",
            True,
            note=note,
        )
    ]


def _session_row(quick: bool, tmp: Path) -> list[Row]:
    """A session's own stepping (the sans-I/O core, no client) on a real robot: recording as
    a fast-clock CI run records (states, /joint_states, /tf, /clock, controller states) vs
    the same core without a recorder."""
    import warnings

    from harness.models import load_robot
    from harness.session import Session
    from tests.models.paths import robots_dir

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(robots_dir() / "panda_description/urdf/panda.urdf", cache_dir=tmp)
    steps = 2_000 if quick else 10_000

    def stepping(record: Path | None) -> float:
        with Session(robot, record_to=record) as session:
            session.step(100)

            def work() -> float:
                advance = session.core.advance
                start = time.perf_counter()
                for _ in range(steps):
                    advance()
                return time.perf_counter() - start

            return session.call(work)

    bare = min(stepping(None) for _ in range(3))
    full = min(stepping(tmp / f"session{i}.mcap") for i in range(3))
    return [
        Row(
            "recording: session stepping without clients (Panda), full recording vs none",
            steps / full,
            steps / bare,
            "st/s",
            "report",
            True,
            note=(
                f"SessionCore.advance {bare / steps * 1e6:.1f} us/step without a recorder, "
                f"{(full - bare) / steps * 1e6:.1f} us/step more recording "
                f"(timestep {robot.model.opt.timestep} s)"
            ),
        )
    ]


def run(quick: bool) -> list[Row]:
    with tempfile.TemporaryDirectory() as tmp:
        rows = _writer_rows(quick, Path(tmp)) + _loop_rows(quick, Path(tmp))
        rows += _sim_row(quick, Path(tmp))
        rows += _session_row(quick, Path(tmp))
    for row in rows:
        print(f"  {row.name}: {row.note}")
    return rows
