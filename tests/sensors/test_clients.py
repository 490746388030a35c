"""Independent clients receive camera images over the bridge with rosbridge compression:
roslibjs (``cbor`` and ``png``) and roslibpy (``png``: roslibpy 2.1 cannot receive binary
frames, so ``cbor`` is not possible with it; its ``png`` op is decoded by a registered
handler, as roslibpy's API provides)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.session import Session
from tests.sensors.sensor_helpers import RIG

NODE_DIR = Path(__file__).resolve().parents[1] / "node"
NODE = shutil.which("node")
CAMERA = [{"name": "cam", "type": "camera", "parent": "mount", "width": 32, "height": 24}]
GREEN = [0, 255, 0]


@pytest.mark.node
@pytest.mark.skipif(NODE is None, reason="node is not installed")
@pytest.mark.skipif(
    not (NODE_DIR / "node_modules" / "roslib").is_dir(),
    reason="tests/node/node_modules lacks roslib (run `make node-deps`)",
)
@pytest.mark.slow
def test_roslibjs_receives_an_image_with_cbor_and_png() -> None:
    assert NODE is not None
    with Session(RIG, sensors=CAMERA) as session:
        proc = subprocess.run(
            [NODE, str(NODE_DIR / "sensors_roslibjs.mjs"), session.url, "/cam/image_raw"],
            cwd=NODE_DIR, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert lines[-1] == "done", proc.stdout
    got = {r["compression"]: r for r in map(json.loads, lines[:-1])}
    for compression in ("cbor", "png"):
        image = got[compression]
        assert (image["width"], image["height"], image["encoding"]) == (32, 24, "rgb8")
        assert image["bytes"] == 32 * 24 * 3
        assert image["frame_id"] == "cam_optical"
        assert image["centre"] == GREEN
    assert got["cbor"]["data_type"] == "Uint8Array"  # binary CBOR, not base64 text


ROSLIBPY = """
import base64, io, json, sys, threading
import roslibpy
from PIL import Image

ros = roslibpy.Ros("127.0.0.1", int(sys.argv[1]))
ros.run()
got = threading.Event()
out = {}

def on_png(message):  # rosbridge's png op: a PNG whose pixels are the JSON frame's bytes
    raw = Image.open(io.BytesIO(base64.b64decode(message["data"]))).tobytes()
    frame = json.loads(raw.rstrip(b"\\n").rstrip(b"\\x00").decode())
    ros.factory._proto.on_message(json.dumps(frame).encode())

ros.factory._proto.register_message_handlers("png", on_png)

def on_image(msg):
    data = base64.b64decode(msg["data"])
    centre = ((msg["height"] // 2) * msg["width"] + msg["width"] // 2) * 3
    out.update(width=msg["width"], height=msg["height"], encoding=msg["encoding"],
               centre=list(data[centre:centre + 3]), bytes=len(data))
    got.set()

topic = roslibpy.Topic(ros, "/cam/image_raw", "sensor_msgs/msg/Image", compression="png")
topic.subscribe(on_image)
threading.Event().wait(0.3)
roslibpy.Service(ros, "/harness/step", "harness_msgs/srv/Step").call(
    roslibpy.ServiceRequest({"steps": 60}), timeout=20)
ok = got.wait(20)
print(json.dumps(out) if ok else "FAIL no image")
ros.terminate()
"""


@pytest.mark.slow
def test_roslibpy_receives_an_image_with_png() -> None:
    pytest.importorskip("PIL", reason="Pillow decodes rosbridge's png op (an independent decoder)")
    with Session(RIG, sensors=CAMERA) as session:
        port = session.url.rsplit(":", 1)[1].split("/")[0]
        proc = subprocess.run(
            [sys.executable, "-c", ROSLIBPY, port], capture_output=True, text=True, timeout=60
        )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    image = json.loads(proc.stdout.splitlines()[-1])
    assert image == {"width": 32, "height": 24, "encoding": "rgb8", "centre": GREEN, "bytes": 2304}


async def _throttled(url: str) -> list[int]:
    """Stamps of the images a raw client gets with throttle_rate 100 ms (50 Hz camera)."""
    import asyncio

    import websockets

    stamps: list[int] = []
    async with websockets.connect(url, max_size=None) as ws:
        await ws.send(
            json.dumps({"op": "subscribe", "topic": "/cam/image_raw", "throttle_rate": 100})
        )
        await ws.send(
            json.dumps({"op": "call_service", "service": "/harness/step", "id": "s",
                        "args": {"steps": 250}})
        )  # fmt: skip
        while True:
            frame = json.loads(await asyncio.wait_for(ws.recv(), 30))
            if frame["op"] == "service_response":
                return stamps
            stamp = frame["msg"]["header"]["stamp"]
            stamps.append(stamp["sec"] * 10**9 + stamp["nanosec"])


def test_image_subscriptions_honour_throttle_in_simulation_time() -> None:
    import asyncio

    camera = [dict(CAMERA[0], update_rate=50)]
    with Session(RIG, sensors=camera) as session:
        stamps = asyncio.run(_throttled(session.url))
    # 50 Hz for 0.5 s would be 25 images; throttled: the first frame, then one per 100 ms
    assert stamps == [20_000_000 + k * 100_000_000 for k in range(5)]


async def _cbor_raw(url: str) -> list[bytes]:
    import asyncio

    import websockets

    frames: list[bytes] = []
    async with websockets.connect(url, max_size=None) as ws:
        await ws.send(
            json.dumps({"op": "subscribe", "topic": "/cam/image_raw", "compression": "cbor-raw"})
        )
        await ws.send(
            json.dumps({"op": "call_service", "service": "/harness/step", "id": "s",
                        "args": {"steps": 60}})
        )  # fmt: skip
        while True:
            frame = await asyncio.wait_for(ws.recv(), 30)
            if isinstance(frame, bytes):
                frames.append(frame)
            elif json.loads(frame)["op"] == "service_response":
                return frames


def test_cbor_raw_carries_the_image_as_cdr() -> None:
    import asyncio

    import cbor2
    import numpy as np

    from harness.recording.layout import typestore

    with Session(RIG, sensors=CAMERA) as session:
        frames = asyncio.run(_cbor_raw(session.url))
    assert len(frames) == 1  # the 10 Hz camera's frame at step 50
    raw = cbor2.loads(frames[0])["msg"]
    assert (raw["secs"], raw["nsecs"]) == (0, 100_000_000)
    image = typestore().deserialize_cdr(raw["bytes"], "sensor_msgs/msg/Image")
    pixels = np.asarray(image.data, np.uint8).reshape(24, 32, 3)
    assert pixels[12, 16].tolist() == GREEN
