"""``Player``: serve a recording to rosbridge clients like ``ros2 bag play``, so client code
can be tested against a recorded robot without simulating.

What is played: every typed channel of the recording (``/joint_states``, ``/clock``,
``/tf``, ``/tf_static``, ``/robot_description``, sensor topics, ``/rosout``; not the harness's
own ``/harness/*`` records), each message as recorded, published on an in-process rosbridge
graph (:class:`harness.rosbridge.Bridge` behind :class:`harness.rosbridge.BridgeServer`), so
each client gets them per its own subscription (compression, throttling, queue length).
Topics whose channel offered transient-local QoS (``offered_qos_profiles`` durability 1;
for older files, :func:`harness.recording.layout.is_latched`) are latched: a late
subscriber gets the last message. Topics the recorded robot sent to clients with no typed
channel are played from the recorded outgoing ``publish`` frames (per (topic, step), the
connection that received the most); their type comes from a recorded ``subscribe`` or
``advertise`` frame, and topics of unknown type are skipped (counted). Service answers and
status frames were replies to the recorded clients and are not replayed. Without a recorded
``/clock``, the player publishes one each time its clock moves.

Schedule: a message recorded at sim time ``t`` is published when the playback clock reaches
``t``; the clock runs at ``rate`` x wall time (wall time paces, it is never recorded), or is
moved by hand: ``/harness/step`` (``harness_msgs/srv/Step``: publish the next ``steps`` steps,
answer with the new sim time), ``/harness/pause`` and ``/harness/resume``
(``std_srvs/srv/Empty``). ``start``: ``"on_client"`` (default) holds the clock until a client
subscribes to a played topic (or steps or resumes it), so nothing is published before anyone
listens; ``"paused"`` until ``/harness/step`` or ``/harness/resume``; ``"now"`` at once.

Meshes: when the played ``robot_description`` references meshes the recording carries, they
are served over HTTP on 127.0.0.1 and the played description points at them
(:mod:`harness.replay.assets`), so a viewer shows the robot on any machine
(``serve_meshes=False``: played as recorded).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import cbor2

from harness.errors import RecordingError
from harness.recording import (
    ATTACHMENT_SOURCE_LINKS,
    ATTACHMENT_SOURCE_PREFIX,
    TOPIC_CLOCK,
    Recording,
    is_latched,
    mesh_attachment_name,
    parse_source_links,
    to_plain,
)
from harness.replay.assets import AssetServer, rewrite_mesh_uris
from harness.replay.errors import RecordedDataError
from harness.replay.source import open_recording
from harness.rosbridge import Bridge, BridgeServer, ServiceCall

__all__ = ["PLAY_STARTS", "PlayItem", "PlayStart", "Player", "load_schedule"]

_DIRECTION_IN, _DIRECTION_OUT = 0, 1
PlayStart = Literal["now", "paused", "on_client"]
PLAY_STARTS: tuple[PlayStart, ...] = ("now", "paused", "on_client")
_CLIENT_POLL_S = 0.01


@dataclass(frozen=True)
class PlayItem:
    """One message to publish at ``step``."""

    step: int
    sim_time_ns: int
    topic: str
    type: str
    msg: dict[str, Any]
    latched: bool = False


def _decode(payload: str | bytes) -> dict[str, Any] | None:
    try:
        frame = json.loads(payload) if isinstance(payload, str) else cbor2.loads(payload)
    except (ValueError, cbor2.CBORDecodeError):
        return None
    return frame if isinstance(frame, dict) else None


def _latched(rec: Recording) -> set[str]:
    """Topics whose channel offered transient-local QoS (or, without QoS, latched by name)."""
    out: set[str] = set()
    for channel in rec.scan.channels.values():
        qos = channel.metadata.get("offered_qos_profiles", "")
        if "durability: 1" in qos or (not qos and is_latched(channel.topic)):
            out.add(channel.topic)
    return out


def load_schedule(rec: Recording) -> tuple[list[PlayItem], dict[str, int]]:
    """The messages to play, in recorded order, and the skipped-frame counts by reason."""
    typed = {t: info.msgtype for t, info in rec.topics.items() if not t.startswith("/harness/")}
    latched = _latched(rec)
    dt_ns = rec.timestep_ns
    items: list[PlayItem] = [
        PlayItem(m.sim_time_ns // dt_ns, m.sim_time_ns, m.topic, m.msgtype, to_plain(m.msg),
                 m.topic in latched)
        for m in rec.messages(list(typed), decode=True)
    ]  # fmt: skip
    types = dict(typed)
    per_key: dict[tuple[str, int], dict[int, list[tuple[int, dict[str, Any]]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    skipped: dict[str, int] = defaultdict(int)
    for frame in rec.bridge_frames():
        if frame.direction == _DIRECTION_IN:
            if frame.op in ("subscribe", "advertise"):
                decoded = _decode(frame.payload)
                if decoded and isinstance(decoded.get("type"), str) and frame.topic:
                    types.setdefault(frame.topic, decoded["type"])
            continue
        if frame.op != "publish":
            skipped[f"op {frame.op or '?'}"] += 1
            continue
        if frame.topic in typed:
            continue  # played from its typed channel
        decoded = _decode(frame.payload)
        msg = decoded.get("msg") if decoded else None
        if not isinstance(msg, dict):
            skipped["undecodable publish"] += 1
            continue
        per_key[(frame.topic, frame.step)][frame.connection].append((frame.sim_time_ns, msg))
    for (topic, step), by_connection in per_key.items():
        msgtype = types.get(topic)
        if msgtype is None:
            skipped[f"unknown type of {topic}"] += 1
            continue
        chosen = max(by_connection.values(), key=len)
        items.extend(PlayItem(step, t, topic, msgtype, msg) for t, msg in chosen)
    items.sort(key=lambda i: i.sim_time_ns)  # stable: recorded order within a step
    return items, dict(skipped)


def _is_description(item: PlayItem) -> bool:
    return item.topic.rsplit("/", 1)[-1] == "robot_description" and isinstance(
        item.msg.get("data"), str
    )


def _referenced_meshes(rec: Recording, items: list[PlayItem]) -> dict[str, bytes]:
    """The attachments the played descriptions' ``<mesh filename>`` references name."""
    names = set(rec.attachment_names)
    links = _links(rec)  # a mesh whose bytes another attachment carries
    wanted: set[str] = set()
    for item in items:
        if _is_description(item):
            for uri in re.findall(
                r"<mesh\b[^>]*?\bfilename\s*=\s*[\"']([^\"']*)", item.msg["data"]
            ):
                name = mesh_attachment_name(uri)
                if name is not None and (name in names or links.get(name) in names):
                    wanted.add(name)
    out: dict[str, bytes] = {}
    for name in sorted(wanted):
        with contextlib.suppress(RecordingError):  # a damaged attachment is not served
            out[name] = rec.attachment(links.get(name, name))
    return out


def _links(rec: Recording) -> dict[str, str]:
    """The recording's source links (:mod:`harness.recording.sourcelinks`) as full
    attachment names; none when they do not read."""
    if ATTACHMENT_SOURCE_LINKS not in rec.attachment_names:
        return {}
    try:
        links = parse_source_links(rec.attachment(ATTACHMENT_SOURCE_LINKS))
    except (RecordingError, ValueError):
        return {}
    return {
        ATTACHMENT_SOURCE_PREFIX + name: ATTACHMENT_SOURCE_PREFIX + target
        for name, target in links.items()
    }


def _with_meshes(item: PlayItem, url: str, meshes: dict[str, bytes]) -> PlayItem:
    if not _is_description(item):
        return item
    msg = {**item.msg, "data": rewrite_mesh_uris(item.msg["data"], url, meshes)}
    return PlayItem(item.step, item.sim_time_ns, item.topic, item.type, msg, item.latched)


class Player:
    """Serve the recording at ``path`` on ``ws://host:port`` (port 0: any free port)."""

    def __init__(
        self,
        path: str | Path,
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        rate: float = 1.0,
        start: PlayStart = "on_client",
        token: str | None = None,
        serve_meshes: bool = True,
    ) -> None:
        if not rate > 0:
            raise RecordedDataError(f"rate must be > 0, got {rate!r}")
        if start not in PLAY_STARTS:
            raise RecordedDataError(f"start must be one of {', '.join(PLAY_STARTS)}, got {start!r}")
        with open_recording(path) as rec:
            self.items, self.skipped = load_schedule(rec)
            self.dt_ns = rec.timestep_ns
            self.first_step = rec.first_step
            self.last_step = rec.last_step
            self._meshes = _referenced_meshes(rec, self.items) if serve_meshes else {}
        self.assets: AssetServer | None = None
        self.rate = rate
        self.start_mode: PlayStart = start
        self.paused = start != "now"
        self.waiting_for_client = start == "on_client"
        self.bridge = Bridge()
        self.server = BridgeServer(self.bridge, host=host, port=port, token=token)
        self.step = self.first_step
        self._next = 0
        self._wake = asyncio.Event()
        self.finished = asyncio.Event()
        for topic, msgtype, latched in sorted({(i.topic, i.type, i.latched) for i in self.items}):
            self.bridge.advertise(topic, msgtype, latch=latched)
        self.topics = sorted({i.topic for i in self.items})
        self._clock = not any(i.topic == TOPIC_CLOCK for i in self.items)
        if self._clock:
            self.bridge.advertise(TOPIC_CLOCK, "rosgraph_msgs/msg/Clock")
        self.bridge.advertise_service("/harness/step", "harness_msgs/srv/Step", self._on_step)
        self.bridge.advertise_service("/harness/pause", "std_srvs/srv/Empty", self._on_pause)
        self.bridge.advertise_service("/harness/resume", "std_srvs/srv/Empty", self._on_resume)

    @property
    def sim_time_ns(self) -> int:
        """The playback clock: every message up to it has been published."""
        return self.step * self.dt_ns

    async def start(self) -> str:
        """Start serving; returns the URL."""
        if self._meshes and self.assets is None:
            self.assets = AssetServer(self._meshes)
            self.items = [_with_meshes(i, self.assets.url, self._meshes) for i in self.items]
        return await self.server.start()

    async def stop(self) -> None:
        """Stop serving."""
        try:
            await self.server.stop()
        finally:
            if self.assets is not None:
                self.assets.close()
                self.assets = None

    def advance_to(self, step: int) -> int:
        """Publish every message recorded up to ``step``; returns how many."""
        count = 0
        before = self.step
        self.step = max(self.step, min(step, self.last_step))
        while self._next < len(self.items) and self.items[self._next].step <= self.step:
            item = self.items[self._next]
            self.bridge.publish(
                item.topic, item.type, item.msg, item.sim_time_ns, latch=item.latched
            )
            self._next += 1
            count += 1
        if self._clock and self.step != before:
            sec, nanosec = divmod(self.sim_time_ns, 1_000_000_000)
            clock = {"clock": {"sec": sec, "nanosec": nanosec}}
            self.bridge.publish(TOPIC_CLOCK, "rosgraph_msgs/msg/Clock", clock, self.sim_time_ns)
        if self.step >= self.last_step:
            self.finished.set()
        self.server.flush()
        return count

    def _on_step(self, call: ServiceCall) -> dict[str, Any]:
        self.waiting_for_client = False
        steps = int(call.args.get("steps", 1) or 1)
        self.advance_to(self.step + steps)
        sec, nanosec = divmod(self.sim_time_ns, 1_000_000_000)
        return {"sim_time": {"sec": sec, "nanosec": nanosec}}

    def _on_pause(self, call: ServiceCall) -> dict[str, Any]:
        self.paused = True
        self._wake.set()
        return {}

    def _on_resume(self, call: ServiceCall) -> dict[str, Any]:
        self.waiting_for_client = False
        self.paused = False
        self._wake.set()
        return {}

    async def run(self) -> None:
        """Play until the end of the recording (paced at ``rate``; paused when asked)."""
        loop = asyncio.get_running_loop()
        while self.waiting_for_client:
            # The clock holds until someone listens (wall-clock polling paces only this wait).
            if any(self.bridge.subscribers_of(t) for t in self.topics):
                self.waiting_for_client = False
                self.paused = False
                break
            await asyncio.sleep(_CLIENT_POLL_S)
        while self.step < self.last_step:
            if self.paused:
                self._wake.clear()
                await self._wake.wait()
                continue
            origin_wall, origin_ns = loop.time(), self.sim_time_ns
            while not self.paused and self.step < self.last_step:
                elapsed_ns = (loop.time() - origin_wall) * self.rate * 1e9
                self.advance_to((origin_ns + int(elapsed_ns)) // self.dt_ns)
                if self._next < len(self.items):
                    wait_ns = self.items[self._next].sim_time_ns - origin_ns - elapsed_ns
                else:
                    wait_ns = (self.last_step * self.dt_ns) - origin_ns - elapsed_ns
                self._wake.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(
                        self._wake.wait(), timeout=max(wait_ns / 1e9 / self.rate, 0.0005)
                    )
        self.finished.set()
