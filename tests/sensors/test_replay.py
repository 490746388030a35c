"""A recording with sensor images replays at --level full: the re-run's sensor messages are
compared with the recorded ones, byte for byte on the same renderer."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from pathlib import Path

import cbor2
import numpy as np
import pytest
import websockets

from harness.recording import Recording
from harness.replay.pipeline import replay_pipeline
from harness.session import Session
from tests.sensors.sensor_helpers import RIG, rewrite_images

SENSORS = [
    {"name": "cam", "type": "rgbd", "parent": "mount", "width": 32, "height": 24},
    {"name": "scan", "type": "lidar", "parent": "mount", "samples": 45, "noise_stddev": 0.01},
    {"name": "imu", "type": "imu", "parent": "mount", "noise_stddev": 0.05},
]


async def _client(url: str, frames: list[bytes | str]) -> None:
    """Subscribe to the image with cbor, the scan as JSON, then step 120 steps."""
    async with websockets.connect(url, max_size=None) as ws:
        for topic, compression in (("/cam/image_raw", "cbor"), ("/scan/scan", "none")):
            await ws.send(
                json.dumps({"op": "subscribe", "topic": topic, "compression": compression})
            )
        await ws.send(
            json.dumps({"op": "call_service", "service": "/harness/step", "id": "s",
                        "args": {"steps": 120}})
        )  # fmt: skip
        while True:
            frame = await asyncio.wait_for(ws.recv(), 30)
            frames.append(frame)
            if isinstance(frame, str) and '"service_response"' in frame:
                return


@pytest.mark.slow
def test_recording_with_images_replays_at_level_full(tmp_path: Path) -> None:
    path = tmp_path / "images.mcap"
    frames: list[bytes | str] = []
    with Session(RIG, sensors=SENSORS, record_to=path, seed=5) as session:
        asyncio.run(_client(session.url, frames))
    images = [cbor2.loads(f)["msg"] for f in frames if isinstance(f, bytes)]
    assert [i["header"]["stamp"]["nanosec"] for i in images] == [100_000_000, 200_000_000]
    pixels = bytes(images[0]["data"])
    centre = (12 * 32 + 16) * 3
    assert pixels[centre : centre + 3] == bytes([0, 255, 0])  # the glowing green cube
    with Recording(path) as rec:
        assert "/cam/image_raw" in rec.topics
        meta = rec.all_metadata
        assert (
            json.loads(meta["harness.sensors"]["topics"])["/cam/image_raw"]
            == "sensor_msgs/msg/Image"
        )
        assert meta["harness.sensors.renderer"]["gl_renderer"]
    report = replay_pipeline(path)
    assert report.reproduced, report.format()
    assert "sensor messages compared" in " ".join(report.notes)
    compared = int(next(n for n in report.notes if "sensor messages" in n).split()[0])
    assert compared == 3 * 4 + 3 + 25  # camera (4 recorded outputs), scans, IMU readings
    cli = subprocess.run(
        [sys.executable, "-m", "harness", "replay", "--level", "full", str(path)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert cli.returncode == 0, cli.stdout + cli.stderr


def test_noise_from_another_seed_is_a_divergence(tmp_path: Path) -> None:
    path = tmp_path / "noise.mcap"
    with Session(RIG, sensors=SENSORS[1:], record_to=path, seed=5) as session:
        session.step(60)
    # the same recording, but the re-run uses another seed: the noisy scan must differ
    from harness.replay import pipeline as pipeline_module

    original = pipeline_module.CoreOptions.from_metadata

    def other_seed(metadata):  # type: ignore[no-untyped-def]
        return original({**metadata, "seed": "6"})

    pipeline_module.CoreOptions.from_metadata = other_seed  # type: ignore[assignment,method-assign]
    try:
        report = replay_pipeline(path)
    finally:
        pipeline_module.CoreOptions.from_metadata = original  # type: ignore[method-assign]
    assert not report.reproduced
    assert report.mismatch is not None
    assert report.mismatch.kind == "sensor"
    assert report.mismatch.topic in ("/scan/scan", "/imu/imu")


def _small_change(pixels: np.ndarray) -> None:
    pixels[:30] = np.clip(pixels[:30].astype(int) + 3, 0, 255).astype(np.uint8)


def _large_change(pixels: np.ndarray) -> None:
    pixels[:] = 255 - pixels


@pytest.mark.slow
def test_images_from_another_renderer_compare_with_a_tolerance_and_a_note(tmp_path: Path) -> None:
    path = tmp_path / "cam.mcap"
    camera = [{"name": "cam", "type": "camera", "parent": "mount", "width": 32, "height": 24}]
    with Session(RIG, sensors=camera, record_to=path) as session:
        session.step(120)
    assert replay_pipeline(path).reproduced
    other = rewrite_images(path, tmp_path / "other.mcap", renderer="SomeGPU 1.0",
                           change=_small_change)  # fmt: skip
    report = replay_pipeline(other)
    assert report.reproduced, report.format()
    assert any("'SomeGPU 1.0'" in n and "tolerance" in n for n in report.notes), report.notes
    # the same small change on the same renderer is a divergence: byte for byte there
    same = rewrite_images(path, tmp_path / "same.mcap", renderer=_renderer(path),
                          change=_small_change)  # fmt: skip
    report = replay_pipeline(same)
    assert not report.reproduced
    assert report.mismatch is not None
    assert report.mismatch.topic == "/cam/image_raw"
    # beyond the tolerance on another renderer: a divergence naming the pixels
    far = rewrite_images(path, tmp_path / "far.mcap", renderer="SomeGPU 1.0",
                         change=_large_change)  # fmt: skip
    report = replay_pipeline(far)
    assert not report.reproduced
    assert report.mismatch is not None
    assert "of the pixels differ beyond the tolerance" in report.mismatch.what


def _renderer(path: Path) -> str:
    with Recording(path) as rec:
        return rec.all_metadata["harness.sensors.renderer"]["gl_renderer"]
