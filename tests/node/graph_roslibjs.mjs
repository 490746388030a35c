// roslibjs (npm roslib 2.1.0, Node >= 20 with `ws`) asks the harness for its graph as tools do.
// Usage: node graph_roslibjs.mjs ws://127.0.0.1:PORT
// getTopics, getNodes, getNodeDetails of every node, getServices, getActionServers,
// getTopicType; steps the lockstep clock; subscribes late to /tf_static. Prints one JSON line,
// then "OK"; exits non-zero with "FAIL <what>: <reason>" otherwise.
import * as ROSLIB from "roslib";

const url = process.argv[2];
const TIMEOUT_MS = 10000;

function ask(name, executor) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`${name}: timed out`)), TIMEOUT_MS);
    executor(
      (value) => { clearTimeout(timer); resolve(value); },
      (err) => { clearTimeout(timer); reject(new Error(`${name}: ${err}`)); },
    );
  });
}

async function main() {
  const ros = new ROSLIB.Ros({ url });
  await ask("connect", (ok, fail) => { ros.on("connection", ok); ros.on("error", fail); });
  const out = {};
  const topics = await ask("getTopics", (ok, fail) => ros.getTopics(ok, fail));
  out.topics = topics.topics;
  out.types = topics.types;
  out.nodes = await ask("getNodes", (ok, fail) => ros.getNodes(ok, fail));
  out.details = {};
  for (const node of out.nodes) {
    out.details[node] = await ask(`getNodeDetails ${node}`, (ok, fail) => ros.getNodeDetails(node, ok, fail));
  }
  out.services = await ask("getServices", (ok, fail) => ros.getServices(ok, fail));
  out.action_servers = await ask("getActionServers", (ok, fail) => ros.getActionServers(ok, fail));
  out.tf_static_type = await ask("getTopicType", (ok, fail) => ros.getTopicType("/tf_static", ok, fail));
  const step = new ROSLIB.Service({ ros, name: "/harness/step", serviceType: "harness_msgs/srv/Step" });
  await ask("step", (ok, fail) => step.callService({ steps: 10 }, ok, fail));
  const late = new ROSLIB.Topic({ ros, name: "/tf_static", messageType: "tf2_msgs/msg/TFMessage" });
  out.tf_static = await ask("late /tf_static", (ok) => late.subscribe(ok));
  console.log(JSON.stringify(out));
  ros.close();
  console.log("OK");
}

main().then(() => process.exit(0), (err) => { console.log(`FAIL ${err.message}`); process.exit(1); });
