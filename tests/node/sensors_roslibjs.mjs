// roslibjs (npm roslib 2.1.0) receives a sensor_msgs/Image from the harness with
// compression "cbor" and "png" (one connection each: rosbridge merges one client's
// subscriptions to a topic). Usage: node sensors_roslibjs.mjs ws://127.0.0.1:PORT TOPIC
// Prints one JSON line per compression, then "done"; exits non-zero on failure.
import * as ROSLIB from "roslib";

const [url, name] = process.argv.slice(2);

function connect() {
  return new Promise((resolve, reject) => {
    const ros = new ROSLIB.Ros({ url });
    ros.on("connection", () => resolve(ros));
    ros.on("error", reject);
  });
}

function bytesOf(data) {
  if (typeof data === "string") return Uint8Array.from(Buffer.from(data, "base64"));
  return Uint8Array.from(data);
}

async function main() {
  const received = {};
  const waits = [];
  const connections = [];
  for (const compression of ["cbor", "png"]) {
    const ros = await connect();
    connections.push(ros);
    const topic = new ROSLIB.Topic({ ros, name, messageType: "sensor_msgs/msg/Image", compression });
    waits.push(new Promise((resolve) => {
      topic.subscribe((msg) => {
        if (received[compression]) return;
        const data = bytesOf(msg.data);
        const centre = ((msg.height >> 1) * msg.width + (msg.width >> 1)) * 3;
        received[compression] = {
          compression, width: msg.width, height: msg.height, encoding: msg.encoding,
          frame_id: msg.header.frame_id, bytes: data.length,
          centre: Array.from(data.slice(centre, centre + 3)),
          data_type: typeof msg.data === "string" ? "base64" : msg.data.constructor.name,
        };
        resolve();
      });
    }));
  }
  await new Promise((r) => setTimeout(r, 300)); // let both subscriptions reach the server
  const step = new ROSLIB.Service({ ros: connections[0], name: "/harness/step", serviceType: "harness_msgs/srv/Step" });
  await new Promise((resolve, reject) => step.callService({ steps: 60 }, resolve, reject));
  const timer = setTimeout(() => { console.log("FAIL timeout " + JSON.stringify(received)); process.exit(1); }, 20000);
  await Promise.all(waits);
  clearTimeout(timer);
  for (const c of ["cbor", "png"]) console.log(JSON.stringify(received[c]));
  console.log("done");
  for (const ros of connections) ros.close();
  process.exit(0);
}

main().catch((e) => { console.log(`FAIL ${e}`); process.exit(1); });
