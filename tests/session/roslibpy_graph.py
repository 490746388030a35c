"""A roslibpy client run in its own process (twisted's reactor runs once per process):
python roslibpy_graph.py PORT

Asks rosapi for the graph as tools do (get_topics; get_topic_type, get_message_details and
/rosapi/publishers of each; get_nodes; get_node_details of every node; get_services;
get_action_servers), steps the lockstep clock, then subscribes late to /tf_static. Prints
everything as one JSON line, then "OK".
"""

from __future__ import annotations

import json
import sys
import threading
from typing import Any

import roslibpy

TIMEOUT = 10.0


def main() -> int:
    ros = roslibpy.Ros("127.0.0.1", int(sys.argv[1]))
    ros.run(timeout=TIMEOUT)
    out: dict[str, Any] = {"topics": ros.get_topics(), "nodes": ros.get_nodes()}
    out["types"] = [ros.get_topic_type(topic) for topic in out["topics"]]
    out["message_details"] = {
        t: ros.get_message_details(t)["typedefs"][0]["type"] for t in set(out["types"])
    }
    publishers = roslibpy.Service(ros, "/rosapi/publishers", "rosapi/Publishers")
    out["publishers"] = {
        t: publishers.call(roslibpy.ServiceRequest({"topic": t}), timeout=TIMEOUT)["publishers"]
        for t in out["topics"]
    }
    out["details"] = {node: ros.get_node_details(node) for node in out["nodes"]}
    out["services"] = ros.get_services()
    out["tf_static_type"] = ros.get_topic_type("/tf_static")
    servers: list[list[str]] = []
    got_servers = threading.Event()
    ros.get_action_servers(lambda r: (servers.append(r["action_servers"]), got_servers.set()))
    if not got_servers.wait(TIMEOUT):
        print("no answer from /rosapi/action_servers", flush=True)
        return 1
    out["action_servers"] = servers[0]
    step = roslibpy.Service(ros, "/harness/step", "harness_msgs/Step")
    step.call(roslibpy.ServiceRequest({"steps": 10}), timeout=TIMEOUT)
    static: list[dict[str, Any]] = []
    got_static = threading.Event()
    listener = roslibpy.Topic(ros, "/tf_static", "tf2_msgs/TFMessage")
    listener.subscribe(lambda m: (static.append(m), got_static.set()))
    if not got_static.wait(TIMEOUT):
        print("no latched /tf_static for a late subscriber", flush=True)
        return 1
    out["tf_static"] = static[0]
    print(json.dumps(out), flush=True)
    ros.terminate()
    print("OK", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
