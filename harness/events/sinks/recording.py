"""The sink into the run's recording: collision events and ``/rosout``.

Collision begins, ends and near misses go to ``/harness/collisions``
(``harness_msgs/msg/CollisionEvent``); every event except joint samples (the recording already
holds ``/joint_states`` and the full state) also goes to ``/rosout`` as a human-readable line.
"""

from __future__ import annotations

from typing import Protocol

from harness.events.errors import SinkError
from harness.events.events import (
    CollisionBegin,
    CollisionEnd,
    Event,
    JointSample,
    LogMessage,
    NearMiss,
)
from harness.events.sinks.base import SinkReport
from harness.recording import CollisionEvent, RosoutRecord

__all__ = ["KIND_BEGIN", "KIND_END", "KIND_NEAR_MISS", "EventRecorder", "RecordingSink"]


KIND_BEGIN = 0
KIND_END = 1
KIND_NEAR_MISS = 2


class EventRecorder(Protocol):
    """The part of ``harness.recording.Recorder`` this sink uses."""

    def write_collision_event(self, record: CollisionEvent) -> None: ...

    def write_rosout(self, record: RosoutRecord) -> None: ...


class RecordingSink:
    """Writes events through ``recorder`` (synchronously: the recorder is the run's own file).

    ``rosout``: also write a ``/rosout`` line for every event that is not a joint sample.
    A recorder error is raised as :class:`SinkError` naming the event and step.
    """

    name = "recording"

    def __init__(self, recorder: EventRecorder, *, rosout: bool = True) -> None:
        self.recorder = recorder
        self.rosout = rosout
        self._delivered = 0
        self._report: SinkReport | None = None

    def emit(self, event: Event) -> None:
        """Write ``event`` (joint samples are not carried)."""
        if isinstance(event, JointSample):
            return
        try:
            self._write(event)
        except Exception as exc:
            raise SinkError(
                f"recording sink: cannot write {event.kind} at step {event.step}: {exc}"
            ) from exc
        self._delivered += 1

    def _write(self, event: Event) -> None:
        if isinstance(event, (CollisionBegin, CollisionEnd, NearMiss)):
            duration_ns, distance, begin_step, end_step = 0, 0.0, 0, 0
            if isinstance(event, NearMiss):
                kind, penetration, force = KIND_NEAR_MISS, 0.0, 0.0
                distance = event.distance
            else:
                kind = KIND_END if isinstance(event, CollisionEnd) else KIND_BEGIN
                penetration, force = event.penetration, event.normal_force
                if isinstance(event, CollisionEnd):
                    duration_ns = event.duration_ns
                    begin_step, end_step = event.begin_step, event.end_step
            self.recorder.write_collision_event(
                CollisionEvent(
                    step=event.step,
                    sim_time_ns=event.sim_time_ns,
                    kind=kind,
                    robot=event.robot,
                    body1=event.body1,
                    body2=event.body2,
                    geom1=event.geom1,
                    geom2=event.geom2,
                    penetration=penetration,
                    normal_force=force,
                    position=event.position,
                    normal=event.normal,
                    duration_ns=duration_ns,
                    distance=distance,
                    begin_step=begin_step,
                    end_step=end_step,
                )
            )
        if self.rosout:
            name = event.name if isinstance(event, LogMessage) else f"harness.{event.kind}"
            self.recorder.write_rosout(
                RosoutRecord(
                    sim_time_ns=event.sim_time_ns,
                    level=int(event.level),
                    name=name,
                    msg=event.message(),
                )
            )

    def close(self) -> SinkReport:
        """Report; the recorder itself is closed by its owner (the session)."""
        if self._report is None:
            self._report = SinkReport(self.name, self._delivered, 0)
        return self._report
