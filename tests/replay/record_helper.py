"""Record a real Simulation run with the real Recorder, the way the session does.

``record(path, commands, steps)``: ``commands`` maps a step index (the number of steps taken
when the command is given) to joint position targets; every step records the applied input
when it changed, the physics state, collision begin/end events and, every 10 steps,
``/joint_states`` (as a topic and as an outgoing bridge frame).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from harness.models import LoadedRobot, load_robot
from harness.recording import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    PhysicsState,
    Recorder,
    describe_run,
)
from harness.sim import Simulation
from harness.sim.collisions import CollisionTracker
from harness.vocabulary import LimitPolicy

__all__ = ["BACK", "REACH", "demo_robot", "record"]

REACH = {"joint1": 0.4, "joint2": 0.1, "joint4": -2.0, "joint6": 1.9}
"""A reach towards the table (position targets)."""
BACK = {"joint1": -0.3, "joint2": -0.5, "joint4": -2.4}
"""And back."""

_ROBOTS: dict[str, LoadedRobot] = {}


def demo_robot(control: str = "position") -> LoadedRobot:
    """The demo robot on the table scene, loaded once per process per control mode."""
    if control not in _ROBOTS:
        _ROBOTS[control] = load_robot("demo", control=control)  # type: ignore[arg-type]
    return _ROBOTS[control]


def _stamp(ns: int) -> dict[str, int]:
    sec, nanosec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def record(
    path: Path,
    commands: Mapping[int, Mapping[str, float]],
    steps: int,
    *,
    control: str = "position",
    kinematic_limits: LimitPolicy | str = LimitPolicy.CLAMP,
    with_mjb: bool = True,
    joint_states_every: int = 10,
    chunk_size: int = 1024 * 1024,
    state_every: int = 1,
) -> Path:
    """Run the demo robot ``steps`` steps applying ``commands`` and record it to ``path``."""
    robot = demo_robot(control)
    sim = Simulation(robot, kinematic_limits=kinematic_limits)
    sim.reset()
    description = describe_run(robot, seed=1)
    attachments = dict(description.attachments)
    if with_mjb:
        attachments["model.mjb"] = robot.mjb
    else:
        attachments.pop("model.mjb", None)
    names = [sim.body_name(b) for b in range(sim.model.nbody)]
    geoms = [sim.geom_name(g) for g in range(sim.model.ngeom)]
    tracker = CollisionTracker(debounce_steps=5)
    seq = 0
    recorder = Recorder(
        path,
        metadata=description.metadata,
        attachments=attachments,
        chunk_size=chunk_size,
        state_every=state_every,
    )
    with recorder as rec:
        state = sim.get_state()
        rec.write_physics_state(PhysicsState(
            step=0, sim_time_ns=0, state_spec=sim.state_spec, state=state,
            qpos=sim.data.qpos, qvel=sim.data.qvel,
        ))  # fmt: skip
        for k in range(steps):
            if k in commands:
                sim.set_positions(dict(commands[k]))
            sim.step()
            now = sim.sim_time_ns
            if sim.input_changed:
                inp = sim.last_input
                assert inp is not None
                rec.write_applied_input(AppliedInput(
                    step=inp.step, sim_time_ns=inp.sim_time_ns, ctrl=inp.ctrl,
                    kinematic_joints=inp.kinematic_joints, qpos_index=inp.qpos_index,
                    qpos_value=inp.qpos_value, qvel_index=inp.qvel_index,
                    qvel_value=inp.qvel_value, mocap_pos=inp.mocap_pos,
                    mocap_quat=inp.mocap_quat, qfrc_applied=inp.qfrc_applied,
                    xfrc_applied=inp.xfrc_applied,
                ))  # fmt: skip
            rec.write_physics_state(PhysicsState(
                step=sim.step_index, sim_time_ns=now, state_spec=sim.state_spec,
                state=sim.get_state(), qpos=sim.data.qpos, qvel=sim.data.qvel,
            ))  # fmt: skip
            for t in tracker.update(sim.step_index, now, sim.contacts()):
                rec.write_collision_event(CollisionEvent(
                    step=t.step, sim_time_ns=t.sim_time_ns, kind=0 if t.kind == "begin" else 1,
                    robot=robot.name, body1=names[t.body1], body2=names[t.body2],
                    geom1=geoms[t.geom1], geom2=geoms[t.geom2], penetration=t.penetration,
                    normal_force=t.normal_force, position=t.position, normal=t.normal,
                    duration_ns=t.duration_ns,
                ))  # fmt: skip
            if joint_states_every and sim.step_index % joint_states_every == 0:
                msg = {
                    "header": {"stamp": _stamp(now), "frame_id": ""},
                    "name": list(sim.joint_names),
                    "position": sim.joint_positions().tolist(),
                    "velocity": sim.joint_velocities().tolist(),
                    "effort": np.asarray(sim.joint_efforts()).tolist(),
                }
                rec.write_message(
                    "/joint_states", "sensor_msgs/msg/JointState", msg, sim_time_ns=now
                )
                frame = json.dumps({"op": "publish", "topic": "/joint_states", "msg": msg})
                rec.write_bridge_frame(BridgeFrame(
                    step=sim.step_index, sim_time_ns=now, direction=1, connection=1, seq=seq,
                    op="publish", topic="/joint_states", text=frame,
                ))  # fmt: skip
                seq += 1
    return path
