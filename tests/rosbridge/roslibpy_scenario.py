"""A roslibpy client scenario run in its own process (twisted's reactor runs once per process).

python roslibpy_scenario.py PORT TRANSPORT

Prints one line per step; the driving test reads them. On "RECONNECT?" it waits for a line on
stdin (the test has closed the connection server-side meanwhile) and checks that roslibpy
reconnects and its subscription works again. Exits 0 when every step passed.
"""

from __future__ import annotations

import sys
import threading

import roslibpy

TIMEOUT = 10.0


def wait(event: threading.Event, what: str) -> None:
    if not event.wait(TIMEOUT):
        print(f"FAIL {what}", flush=True)
        sys.exit(1)


def main() -> int:
    port, transport = int(sys.argv[1]), sys.argv[2]
    ros = roslibpy.Ros("127.0.0.1", port, transport=transport)
    ros.run()
    print("connected", flush=True)

    # pub/sub: our own subscription receives what we publish
    got: list[str] = []
    five = threading.Event()

    def on_chatter(msg: dict) -> None:
        got.append(msg["data"])
        if len(got) >= 5:
            five.set()

    sub = roslibpy.Topic(ros, "/chatter", "std_msgs/String")
    sub.subscribe(on_chatter)
    pub = roslibpy.Topic(ros, "/chatter", "std_msgs/String")
    pub.advertise()
    tick = threading.Event()
    while not five.is_set():
        pub.publish(roslibpy.Message({"data": f"hello {len(got)}"}))
        tick.wait(0.05)
    print(f"pubsub {got[0]}", flush=True)

    # rosapi
    topics = ros.get_topics()
    assert "/chatter" in topics, topics
    assert "/rosapi/topics" in ros.get_services()
    assert ros.get_topic_type("/chatter") == "std_msgs/msg/String"
    details = ros.get_message_details("std_msgs/Header")
    assert details["typedefs"][0]["fieldnames"] == ["stamp", "frame_id"], details
    param = roslibpy.Param(ros, "/gain")
    param.set({"k": 2.5})
    assert param.get() == {"k": 2.5}
    print("rosapi ok", flush=True)

    # services both ways: a harness service, then one this client provides
    add = roslibpy.Service(ros, "/add_two_ints", "example_interfaces/AddTwoInts")
    assert add.call(roslibpy.ServiceRequest({"a": 2, "b": 40}), timeout=TIMEOUT)["sum"] == 42

    def set_flag(request: dict, response: dict) -> bool:
        response["success"] = request["data"]
        response["message"] = "flag set"
        return True

    server = roslibpy.Service(ros, "/set_flag", "std_srvs/SetBool")
    server.advertise(set_flag)
    client = roslibpy.Service(ros, "/set_flag", "std_srvs/SetBool")
    answer = client.call(roslibpy.ServiceRequest({"data": True}), timeout=TIMEOUT)
    assert answer["success"] is True, answer
    assert answer["message"] == "flag set", answer
    missing = roslibpy.Service(ros, "/nope", "std_srvs/Trigger")
    try:
        missing.call(roslibpy.ServiceRequest({}), timeout=TIMEOUT)
    except roslibpy.core.ServiceException as exc:
        assert "does not exist" in str(exc), exc  # noqa: PT017 (a script, not a pytest test)
    else:
        raise AssertionError("call to a missing service succeeded")
    print("services ok", flush=True)

    # actions
    feedback: list[list[int]] = []
    results: list[dict] = []
    done = threading.Event()
    action = roslibpy.ActionClient(ros, "/fibonacci", "example_interfaces/action/Fibonacci")
    action.send_goal(
        roslibpy.Goal({"order": 5}),
        lambda r: (results.append(r), done.set()),
        lambda f: feedback.append(f["partial_sequence"]),
        lambda e: (results.append({"error": e}), done.set()),
    )
    wait(done, "action result")
    assert results[0]["values"]["sequence"] == [0, 1, 1, 2, 3, 5], results
    assert getattr(results[0]["status"], "value", results[0]["status"]) == 4, results
    assert len(feedback) == 4, feedback
    print("actions ok", flush=True)

    # reconnect: the test closes our connection; roslibpy reconnects and re-subscribes
    after = threading.Event()
    sub2 = roslibpy.Topic(ros, "/after", "std_msgs/String")
    sub2.subscribe(lambda m: after.set())
    print("RECONNECT?", flush=True)
    sys.stdin.readline()
    pub2 = roslibpy.Topic(ros, "/after", "std_msgs/String")
    pub2.advertise()
    for _ in range(int(TIMEOUT / 0.1)):
        if after.is_set():
            break
        if ros.is_connected:
            pub2.publish(roslibpy.Message({"data": "again"}))
        tick.wait(0.1)
    wait(after, "message after reconnect")
    print("reconnect ok", flush=True)
    ros.terminate() if transport == "twisted" else ros.close()
    print("OK", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
