"""A client under test for the runner tests. Usage: client.py MODE PIDFILE

Writes its pid (and a child's pid where it has one) to PIDFILE, then, by MODE:
ok: connect to $HARNESS_ROSBRIDGE_URL, exit 0; crash: connect, print an error, exit 3;
hang: connect and block forever; noconnect: block forever without connecting;
stubborn: connect, start a child that ignores SIGTERM, and block forever ignoring SIGTERM.
"""

import os
import signal
import subprocess
import sys
import threading

from websockets.sync.client import connect

mode, pidfile = sys.argv[1], sys.argv[2]
pids = [os.getpid()]
if mode == "stubborn":
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import signal, threading; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
            "threading.Event().wait()",
        ]
    )
    pids.append(child.pid)
with open(pidfile + ".tmp", "w") as f:
    f.write(" ".join(map(str, pids)))
os.replace(pidfile + ".tmp", pidfile)

if mode == "noconnect":
    threading.Event().wait()
ws = connect(os.environ["HARNESS_ROSBRIDGE_URL"])
if mode == "ok":
    ws.close()
    sys.exit(0)
if mode == "crash":
    print("Traceback: simulated failure in the client under test", flush=True)
    sys.exit(3)
threading.Event().wait()
