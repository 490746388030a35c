// roslibjs (npm roslib 2.1.0, Node >= 20 with `ws`) against the harness rosbridge server.
// Usage: node rosbridge_roslibjs.mjs ws://127.0.0.1:PORT
// Prints one line per passed step; exits non-zero with "FAIL <step>: <reason>" otherwise.
import * as ROSLIB from "roslib";

const url = process.argv[2];
const TIMEOUT_MS = 10000;

function step(name, executor) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`${name}: timed out`)), TIMEOUT_MS);
    executor(
      (value) => { clearTimeout(timer); console.log(`${name} ok`); resolve(value); },
      (err) => { clearTimeout(timer); reject(new Error(`${name}: ${err}`)); },
    );
  });
}

function check(cond, what) {
  if (!cond) throw new Error(what);
}

async function main() {
  const ros = new ROSLIB.Ros({ url });
  await step("connect", (ok, fail) => { ros.on("connection", ok); ros.on("error", fail); });
  const statuses = [];
  ros.on("status", (s) => statuses.push(s));

  // pub/sub on our own topic
  const topic = new ROSLIB.Topic({ ros, name: "/js_chatter", messageType: "std_msgs/msg/String" });
  await step("pubsub", (ok) => {
    const got = [];
    topic.subscribe((m) => { got.push(m.data); if (got.length === 5) ok(); });
    topic.advertise();
    for (let i = 0; i < 5; i++) topic.publish({ data: `js ${i}` });
  });

  // rosapi with relative names (roslibjs uses "rosapi/topics")
  await step("rosapi", (ok, fail) => {
    ros.getTopics((r) => {
      if (!r.topics.includes("/js_chatter")) return fail(JSON.stringify(r));
      ros.getMessageDetails("geometry_msgs/msg/Pose", (defs) => {
        const decoded = ros.decodeTypeDefs(defs);
        if (!("position" in decoded) || !("x" in decoded.position)) return fail(JSON.stringify(decoded));
        ok();
      }, fail);
    }, fail);
  });

  // services both ways
  await step("call harness service", (ok, fail) => {
    const add = new ROSLIB.Service({ ros, name: "/add_two_ints", serviceType: "example_interfaces/srv/AddTwoInts" });
    add.callService({ a: 1, b: 2 }, (r) => (r.sum === 3 ? ok() : fail(JSON.stringify(r))), fail);
  });
  const provided = new ROSLIB.Service({ ros, name: "/js_trigger", serviceType: "std_srvs/srv/Trigger" });
  await provided.advertise((req, resp) => { resp.success = true; resp.message = "from js"; return true; });
  await step("provide service", (ok, fail) => {
    const caller = new ROSLIB.Service({ ros, name: "/js_trigger", serviceType: "std_srvs/srv/Trigger" });
    caller.callService({}, (r) => (r.message === "from js" ? ok() : fail(JSON.stringify(r))), fail);
  });
  await step("missing service fails", (ok, fail) => {
    const missing = new ROSLIB.Service({ ros, name: "/nope", serviceType: "std_srvs/srv/Trigger" });
    missing.callService({}, (r) => fail(`unexpected success ${JSON.stringify(r)}`),
      (e) => (String(e).includes("does not exist") ? ok() : fail(e)));
  });

  // actions: the harness's Fibonacci, then one this client provides
  await step("action", (ok, fail) => {
    const fib = new ROSLIB.Action({ ros, name: "/fibonacci", actionType: "example_interfaces/action/Fibonacci" });
    const feedback = [];
    fib.sendGoal({ order: 5 }, (result) => {
      const seq = Array.from(result.sequence ?? result.values?.sequence ?? []);
      if (seq.join(",") !== "0,1,1,2,3,5" || feedback.length !== 4) return fail(JSON.stringify({ result, feedback }));
      ok();
    }, (f) => feedback.push(f), fail);
  });
  await step("provide action", (ok, fail) => {
    const server = new ROSLIB.Action({ ros, name: "/js_fib", actionType: "example_interfaces/action/Fibonacci" });
    server.advertise((goal, id) => {
      server.sendFeedback(id, { partial_sequence: [0, 1] });
      server.setSucceeded(id, { sequence: [0, 1, goal.order] });
    }, () => {});
    const client = new ROSLIB.Action({ ros, name: "/js_fib", actionType: "example_interfaces/action/Fibonacci" });
    const feedback = [];
    client.sendGoal({ order: 9 }, (result) => {
      const seq = Array.from(result.sequence ?? result.values?.sequence ?? []);
      if (seq.join(",") !== "0,1,9" || feedback.length !== 1) return fail(JSON.stringify({ result, feedback }));
      ok();
    }, (f) => feedback.push(f), fail);
  });

  // bad input is answered with a status frame roslibjs surfaces
  await step("status on bad frame", (ok, fail) => {
    // without an id the status arrives as the "status" event (with one: "status:<id>")
    ros.on("status", (s) => (s.level === "error" && String(s.msg).includes("field data") ? ok() : null));
    ros.callOnConnection({ op: "publish", topic: "/js_chatter", msg: { data: 5 } });
  });

  ros.close();
  console.log("OK");
}

main().then(() => process.exit(0), (err) => { console.log(`FAIL ${err.message}`); process.exit(1); });
