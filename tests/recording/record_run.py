"""A realistic recorded run of tests/data/recording/arm.xml driven by raw MuJoCo.

Used in-process by the tests (``record(path, steps)``) and as a child process by the kill -9
test: ``python record_run.py OUT --steps N --flush-interval S`` prints ``FLUSH <sim_time_ns>
<messages>`` after each flush (``--steps 0``: run until killed).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import cbor2
import mujoco
import numpy as np

from harness.recording import (
    AppliedInput,
    BridgeFrame,
    CollisionEvent,
    FlushInfo,
    PhysicsState,
    Recorder,
    RosoutRecord,
)
from harness.sim.contacts import extract_contacts

MODEL = Path(__file__).resolve().parents[1] / "data" / "recording" / "arm.xml"
SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
JOINTS = ("joint1", "joint2", "joint3")


def metadata(model: mujoco.MjModel, text: str) -> dict[str, str]:
    return {
        "robot": "test_arm",
        "timestep": repr(float(model.opt.timestep)),
        "timestep_ns": str(round(model.opt.timestep * 1e9)),
        "integrator": "IMPLICITFAST",
        "seed": "7",
        "model_sha256": hashlib.sha256(text.encode()).hexdigest(),
        "control_modes": json.dumps(dict.fromkeys(JOINTS, "position")),
    }


def _stamp(ns: int) -> dict[str, int]:
    sec, nanosec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def record(
    path: Path,
    steps: int,
    *,
    flush_interval_s: float = 1.0,
    print_flushes: bool = False,
    state_every: int = 1,
    chunk_size: int = 1024 * 1024,
) -> None:
    """Run ``steps`` steps (0: forever) and record everything the harness records."""
    text = MODEL.read_text()
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    dt_ns = round(model.opt.timestep * 1e9)
    state = np.zeros(mujoco.mj_stateSize(model, SPEC))
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(model.nbody)]
    geoms = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) for i in range(model.ngeom)]

    def on_flush(info: FlushInfo) -> None:
        if print_flushes:
            print(f"FLUSH {info.sim_time_ns} {info.messages}", flush=True)

    recorder = Recorder(
        path,
        metadata=metadata(model, text),
        attachments={"model.mjcf.xml": text.encode(), "scenario/run.yaml": b"steps: 1\n"},
        flush_interval_s=flush_interval_s,
        on_flush=on_flush,
        state_every=state_every,
        chunk_size=chunk_size,
    )
    with recorder:
        recorder.write_message(
            "/robot_description", "std_msgs/msg/String", {"data": text}, sim_time_ns=0
        )
        recorder.write_rosout(
            RosoutRecord(sim_time_ns=0, level=20, name="harness", msg="recording started")
        )
        mujoco.mj_getState(model, data, state, SPEC)
        recorder.write_physics_state(
            PhysicsState(
                step=0, sim_time_ns=0, state_spec=SPEC, state=state, qpos=data.qpos, qvel=data.qvel
            )
        )
        seq = 0
        active: dict[tuple[int, int], tuple[int, float, float, np.ndarray, np.ndarray]] = {}
        step = 0
        while steps == 0 or step < steps:
            now = step * dt_ns
            if step % 50 == 0:
                target = [0.8 * np.sin(step / 300.0), 0.6 * np.sin(step / 170.0), 0.3]
                frame = json.dumps(
                    {"op": "publish", "topic": "/joint_command", "msg": {"position": target}}
                )
                recorder.write_bridge_frame(BridgeFrame(
                    step=step, sim_time_ns=now, direction=0, connection=1, seq=seq,
                    op="publish", topic="/joint_command", text=frame,
                ))  # fmt: skip
                seq += 1
                data.ctrl[:] = target
                kinematic = step == 100
                if kinematic:
                    data.qpos[0] = 0.25
                    data.qvel[0] = 0.0
                recorder.write_applied_input(
                    AppliedInput(
                        step=step,
                        sim_time_ns=now,
                        ctrl=data.ctrl,
                        kinematic_joints=["joint1"] if kinematic else [],
                        qpos_index=[0] if kinematic else [],
                        qpos_value=[0.25] if kinematic else [],
                        qvel_index=[0] if kinematic else [],
                        qvel_value=[0.0] if kinematic else [],
                    )
                )
            mujoco.mj_step(model, data)
            step += 1
            now = step * dt_ns
            mujoco.mj_getState(model, data, state, SPEC)
            recorder.write_physics_state(PhysicsState(
                step=step, sim_time_ns=now, state_spec=SPEC, state=state,
                qpos=data.qpos, qvel=data.qvel,
            ))  # fmt: skip
            contacts = extract_contacts(model, data)
            seen = set()
            for i in range(contacts.size):
                pair = (int(contacts.body1[i]), int(contacts.body2[i]))
                seen.add(pair)
                depth, force = float(contacts.depth[i]), float(contacts.normal_force[i])
                if pair not in active:
                    active[pair] = (step, depth, force, contacts.position[i], contacts.normal[i])
                    g1, g2 = int(contacts.geom1[i]), int(contacts.geom2[i])
                    recorder.write_collision_event(CollisionEvent(
                        step=step, sim_time_ns=now, kind=0, robot="test_arm",
                        body1=names[pair[0]], body2=names[pair[1]], geom1=geoms[g1],
                        geom2=geoms[g2], penetration=max(depth, 0.0), normal_force=force,
                        position=contacts.position[i], normal=contacts.normal[i],
                    ))  # fmt: skip
                    recorder.write_rosout(RosoutRecord(
                        sim_time_ns=now, level=30, name="collisions",
                        msg=f"contact {names[pair[0]]} - {names[pair[1]]}",
                        file="record_run.py", function="record", line=1,
                    ))  # fmt: skip
            for pair in [p for p in active if p not in seen]:
                began, depth, force, position, normal = active.pop(pair)
                recorder.write_collision_event(CollisionEvent(
                    step=step, sim_time_ns=now, kind=1, robot="test_arm",
                    body1=names[pair[0]], body2=names[pair[1]], geom1="", geom2="",
                    penetration=max(depth, 0.0), normal_force=force, position=position,
                    normal=normal, duration_ns=(step - began) * dt_ns,
                ))  # fmt: skip
            if step % 10 == 0:
                joint_states = {
                    "header": {"stamp": _stamp(now), "frame_id": ""},
                    "name": list(JOINTS),
                    "position": data.qpos[:3].tolist(),
                    "velocity": data.qvel[:3].tolist(),
                    "effort": data.actuator_force.tolist(),
                }
                recorder.write_message(
                    "/joint_states", "sensor_msgs/msg/JointState", joint_states, sim_time_ns=now
                )
                recorder.write_message(
                    "/clock", "rosgraph_msgs/msg/Clock", {"clock": _stamp(now)}, sim_time_ns=now
                )
                transforms = [
                    {
                        "header": {"stamp": _stamp(now), "frame_id": "world"},
                        "child_frame_id": names[b],
                        "transform": {
                            "translation": dict(zip("xyz", data.xpos[b].tolist(), strict=True)),
                            "rotation": dict(zip("wxyz", data.xquat[b].tolist(), strict=True)),
                        },
                    }
                    for b in range(1, model.nbody)
                ]
                recorder.write_message(
                    "/tf", "tf2_msgs/msg/TFMessage", {"transforms": transforms}, sim_time_ns=now
                )
                frame = json.dumps({"op": "publish", "topic": "/joint_states", "msg": joint_states})
                recorder.write_bridge_frame(BridgeFrame(
                    step=step, sim_time_ns=now, direction=1, connection=1, seq=seq,
                    op="publish", topic="/joint_states", text=frame,
                ))  # fmt: skip
                seq += 1
            if step % 100 == 0:
                blob = cbor2.dumps(
                    {"op": "publish", "topic": "/clock", "msg": {"clock": _stamp(now)}}
                )
                recorder.write_bridge_frame(BridgeFrame(
                    step=step, sim_time_ns=now, direction=1, connection=2, seq=seq,
                    op="publish", topic="/clock", binary=True, data=blob,
                ))  # fmt: skip
                seq += 1


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("out", type=Path)
    parser.add_argument("--steps", type=int, default=0)
    parser.add_argument("--flush-interval", type=float, default=1.0)
    args = parser.parse_args()
    record(args.out, args.steps, flush_interval_s=args.flush_interval, print_flushes=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
