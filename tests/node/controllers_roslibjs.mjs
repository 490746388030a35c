// roslibjs's action client against the demo arm's joint_trajectory_controller, lockstep.
// Usage: node controllers_roslibjs.mjs ws://127.0.0.1:PORT
// Prints one JSON line {feedback, result, rejected, names, positions}; exits non-zero on failure.
import * as ROSLIB from "roslib";

const url = process.argv[2];
const TIMEOUT_MS = 20000;
const JOINTS = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7"];
const TARGET = [0.3, 0.2, 0.1, -1.4, 0.1, 1.8, -0.5];
const ACTION = "/joint_trajectory_controller/follow_joint_trajectory";
const TYPE = "control_msgs/action/FollowJointTrajectory";

function withTimeout(name, executor) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`${name}: timed out`)), TIMEOUT_MS);
    executor((v) => { clearTimeout(timer); resolve(v); }, (e) => { clearTimeout(timer); reject(new Error(`${name}: ${JSON.stringify(e)}`)); });
  });
}

async function main() {
  const ros = new ROSLIB.Ros({ url });
  await withTimeout("connect", (ok, fail) => { ros.on("connection", ok); ros.on("error", fail); });
  const stepSrv = new ROSLIB.Service({ ros, name: "/harness/step", serviceType: "harness_msgs/srv/Step" });
  const stateSrv = new ROSLIB.Service({ ros, name: "/harness/get_state", serviceType: "harness_msgs/srv/GetState" });
  const step = (n) => withTimeout("step", (ok, fail) => stepSrv.callService({ steps: n }, ok, fail));
  const arm = new ROSLIB.Action({ ros, name: ACTION, actionType: TYPE });

  function send(goal) {
    // roslibjs reports an aborted goal through the failed callback: "GoalError: Action was
    // aborted: {result values}"
    const out = { feedback: 0, result: null, aborted: null };
    out.done = new Promise((resolve) => {
      arm.sendGoal(goal, (r) => { out.result = r; resolve(); }, () => { out.feedback += 1; },
        (e) => { out.aborted = String(e); out.result = false; resolve(); });
    });
    return out;
  }
  async function finish(goal) {
    for (let i = 0; i < 80 && goal.result === null; i++) await step(25);
    await withTimeout("result", (ok, fail) => goal.done.then(ok, fail));
    return goal;
  }

  const tolerance = JOINTS.map((name) => ({ name, position: 0.01, velocity: 0, acceleration: 0 }));
  const good = await finish(send({
    trajectory: { joint_names: JOINTS, points: [{ positions: TARGET, time_from_start: { sec: 0, nanosec: 600000000 } }] },
    goal_tolerance: tolerance,
    goal_time_tolerance: { sec: 1, nanosec: 0 },
  }));
  const bad = await finish(send({
    trajectory: { joint_names: ["joint1", "nope"], points: [{ positions: [0, 0], time_from_start: { sec: 1, nanosec: 0 } }] },
  }));
  const state = await withTimeout("state", (ok, fail) => stateSrv.callService({}, ok, fail));
  if (good.aborted !== null) throw new Error(`goal aborted: ${good.aborted}`);
  const result = good.result.values ?? good.result;
  const marker = "aborted: ";
  if (bad.aborted === null) throw new Error(`invalid goal not aborted: ${JSON.stringify(bad.result)}`);
  const rejected = JSON.parse(bad.aborted.slice(bad.aborted.indexOf(marker) + marker.length));
  console.log(JSON.stringify({
    feedback: good.feedback, result, rejected,
    names: state.joint_state.name, positions: state.joint_state.position,
  }));
  ros.close();
}

main().catch((e) => { console.log(`FAIL ${e.message}`); process.exit(1); });
