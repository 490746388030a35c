"""A session's recording file: opened with the run's metadata and the recording sink
(:func:`start_recorder`), and copied complete while the session runs
(:func:`flush_at_boundary` on the session's thread, then :func:`write_snapshot`).

What a session records (``record_to``): every frame in and out of the bridge (incoming frames
with ``step`` = the step before which they took effect and the sim time of the boundary they
were applied at; outgoing with the current step), the applied input whenever it changes, the
physics state every ``state_every`` steps (step 0 included), every published message, and the
loggers' events (collisions, ``/rosout``), plus markers for the inputs that are not client
frames (a socket closing, a wall-clock call timeout, a transport status, a Python command:
:mod:`harness.session.core`). ``record_bridge_frames=False`` leaves out the bridge frames and
markers (such a recording cannot be replayed at ``--level full``).
:meth:`Session.snapshot <harness.session.Session.snapshot>` writes a complete copy of the
recording so far while the session runs (mid-test golden comparisons).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from harness.events import EventHub, RecordingSink
from harness.models import LoadedRobot, LoadedWorld
from harness.recording import Recorder, complete_prefix
from harness.session.core.options import CoreOptions, LoadOptions, RecordOptions, TransportOptions
from harness.session.live.startup import open_recorder
from harness.sim import Simulation

__all__ = ["flush_at_boundary", "start_recorder", "write_snapshot"]


def start_recorder(
    path: Path | None,
    loaded: LoadedRobot | LoadedWorld,
    options: CoreOptions,
    transport: TransportOptions,
    record: RecordOptions,
    load: LoadOptions,
    ros_domain_id: int | None,
) -> tuple[Recorder | None, EventHub]:
    """The session's event hub and, when it records (``path``), its recorder, already a
    sink of the hub (:func:`~harness.session.live.startup.open_recorder`)."""
    hub = EventHub()
    recorder = None
    if path is not None:
        recorder = open_recorder(path, loaded, options, transport, record, load, ros_domain_id)
        hub.add_sink(RecordingSink(recorder))
    return recorder, hub


def flush_at_boundary(
    recorder: Recorder, boundary: Callable[[], None], sim: Simulation
) -> tuple[int, int]:
    """On the session's thread: a step ``boundary`` (frames waiting are applied), then the
    recorder flushed; the step reached and the bytes of the file written so far."""
    boundary()
    recorder.flush()
    return sim.step_index, recorder.stats.file_bytes


def write_snapshot(recorder: Recorder, size: int, path: str | Path) -> None:
    """Write the first ``size`` bytes of ``recorder``'s file (flushed) to ``path`` as a
    complete MCAP file."""
    with open(recorder.path, "rb") as source:
        prefix = source.read(size)
    complete_prefix(prefix, path, recorder.metadata.get("compression", "zstd"))
