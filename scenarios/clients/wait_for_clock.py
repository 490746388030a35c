"""A minimal client under test: connects to the bridge named by HARNESS_ROSBRIDGE_URL with
roslibpy, waits for one /clock message and exits 0 (1 when none arrives within 10 s)."""

import os
import sys
import threading
from urllib.parse import urlparse

import roslibpy

url = urlparse(os.environ["HARNESS_ROSBRIDGE_URL"])
ros = roslibpy.Ros(host=url.hostname, port=url.port)
ros.run()
got = threading.Event()
clock = roslibpy.Topic(ros, "/clock", "rosgraph_msgs/msg/Clock")
clock.subscribe(lambda message: got.set())
ok = got.wait(10.0)
clock.unsubscribe()
ros.terminate()
print("clock received" if ok else "no /clock within 10 s")
sys.exit(0 if ok else 1)
