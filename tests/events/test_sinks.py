"""Recording, JSON lines, stdlib logging and collecting sinks; the registry; the hub."""

from __future__ import annotations

import json
import logging

import pytest

from harness.events import (
    CollectingSink,
    CollisionLogger,
    EventHub,
    JointLimitLogger,
    JointLogger,
    JsonLinesSink,
    Level,
    LoggerConfigError,
    LoggingSink,
    LogMessage,
    RecordingSink,
    SeqSink,
    SinkError,
    available_sinks,
    create_sink,
)
from harness.recording import Recorder, Recording

KINDS = {"collision_begin": 0, "collision_end": 1, "near_miss": 2}


class ListHandler(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.records = []

    def emit(self, record):
        self.records.append(record)


def run_with_sinks(scene, pusher, sinks):
    model = scene.model("workcell.xml")
    loggers = [
        CollisionLogger(model, robot_root="pusher", near_miss_distance=0.01),
        JointLogger(model, rate_hz=50),
        JointLimitLogger(model, velocity_limits={"slide": 0.2}),
    ]
    hub = EventHub(loggers, sinks)
    hub.emit([LogMessage.of(step=0, sim_time_ns=0, robot="robot", text="run starts", name="test")])
    approach = pusher(196)  # stops 3.5 mm short of the block: a near miss

    def script(k, data):
        approach(k, data)
        data.qvel[0] = 0.5 if k < 196 else -0.5  # 1 mm per 2 ms step

    scene.run(model, hub, 450, script, robot="robot")
    return hub


def test_jsonl_and_logging_carry_the_same_events_as_the_recording(scene, pusher, tmp_path):
    logger = logging.getLogger("harness.test.sinks")
    logger.setLevel(logging.DEBUG)
    logger.propagate = False
    handler = ListHandler()
    logger.addHandler(handler)
    path = tmp_path / "run.mcap"
    recorder = Recorder(
        path,
        metadata={
            "timestep": "0.002",
            "integrator": "Euler",
            "seed": "0",
            "model_sha256": "0" * 64,
            "control_modes": "{}",
        },
    )
    collect = CollectingSink()
    sinks = [
        RecordingSink(recorder),
        JsonLinesSink(tmp_path / "events.jsonl"),
        LoggingSink(logger),
        collect,
    ]
    try:
        hub = run_with_sinks(scene, pusher, sinks)
        reports = {r.name: r for r in hub.close()}
    finally:
        recorder.close()
        logger.removeHandler(handler)

    lines = [json.loads(x) for x in (tmp_path / "events.jsonl").read_text().splitlines()]
    extras = [r.harness for r in handler.records]
    assert lines == extras  # same events, same order, same fields
    assert [r.getMessage() for r in handler.records] == [e.message() for e in collect.events]
    assert [r.levelno for r in handler.records] == [int(e.level) for e in collect.events]
    kinds = {line["event"] for line in lines}
    assert {"collision_begin", "collision_end", "near_miss", "joint_sample", "log"} <= kinds
    assert "velocity_limit_exceeded" in kinds  # the pusher moves at 0.5 m/s > 0.2

    with Recording(path) as recording:
        recorded = list(recording.collision_events())
        rosout = [m.msg for m in recording.messages("/rosout", decode=True)]
    collisions = [x for x in lines if x["event"] in KINDS]
    assert len(recorded) == len(collisions) > 0
    for rec, line in zip(recorded, collisions, strict=True):
        assert rec.kind == KINDS[line["event"]]
        assert (rec.step, rec.sim_time_ns, rec.robot) == (
            line["step"],
            line["sim_time_ns"],
            line["robot"],
        )
        assert (rec.body1, rec.body2, rec.geom1, rec.geom2) == (
            line["body1"],
            line["body2"],
            line["geom1"],
            line["geom2"],
        )
        assert list(rec.position) == line["position"]
        assert list(rec.normal) == line["normal"]
        if line["event"] == "near_miss":
            assert rec.distance == line["distance"]
        else:
            assert rec.penetration == line["penetration"]
            assert rec.normal_force == line["normal_force"]
        if line["event"] == "collision_end":
            assert rec.duration_ns == line["duration_ns"]
            assert (rec.begin_step, rec.end_step) == (line["begin_step"], line["end_step"])
            assert rec.end_step > rec.begin_step
    not_samples = [e for e in collect.events if e.kind != "joint_sample"]
    assert [(m.msg, m.level) for m in rosout] == [(e.message(), int(e.level)) for e in not_samples]
    stamps = [m.stamp.sec * 1_000_000_000 + m.stamp.nanosec for m in rosout]
    assert stamps == [e.sim_time_ns for e in not_samples]
    assert reports["recording"].delivered == len(not_samples)
    assert reports["jsonl"].delivered == len(lines) == reports["collect"].delivered
    assert reports["logging"].delivered == len(lines)
    assert all(r.dropped == 0 for r in reports.values())


def test_registry_builds_sinks_by_name(tmp_path):
    assert {"collect", "jsonl", "logging", "recording", "seq"} <= set(available_sinks())
    sink = create_sink("JSONL", path=tmp_path / "x.jsonl")
    assert isinstance(sink, JsonLinesSink)
    sink.emit(LogMessage.of(step=1, sim_time_ns=5, robot="r", text="hi"))
    assert sink.close().delivered == 1
    assert json.loads((tmp_path / "x.jsonl").read_text())["text"] == "hi"
    seq = create_sink("seq", endpoint="http://127.0.0.1:9", close_timeout_s=0.1)
    assert isinstance(seq, SeqSink)
    assert seq.url == "http://127.0.0.1:9/ingest/clef"
    assert seq.close().dropped == 0
    with pytest.raises(LoggerConfigError, match=r"unknown sink 'kafka'.*jsonl"):
        create_sink("kafka")
    with pytest.raises(LoggerConfigError, match=r"sink 'jsonl'.*colour"):
        create_sink("jsonl", path=tmp_path / "y", colour="red")
    with pytest.raises(SinkError, match="cannot open"):
        create_sink("jsonl", path=tmp_path / "missing" / "dir" / "x.jsonl")


class Exploding:
    name = "exploding"

    def __init__(self):
        self.seen = 0

    def emit(self, event):
        self.seen += 1
        if self.seen == 3:
            raise RuntimeError("disk full")

    def close(self):
        from harness.events import SinkReport

        return SinkReport(self.name, self.seen - 1, 0)


def test_a_failing_sink_neither_stops_the_run_nor_hides_its_losses():
    good = CollectingSink()
    bad = Exploding()
    hub = EventHub(sinks=[bad, good])
    events = [LogMessage.of(step=i, sim_time_ns=i, robot="r", text=str(i)) for i in range(10)]
    hub.emit(events)
    reports = {r.name: r for r in hub.close()}
    assert good.events == events
    assert reports["exploding"].delivered == 2
    assert reports["exploding"].dropped == 8  # the failing event and the 7 after it
    assert "RuntimeError: disk full" in reports["exploding"].note
    assert hub.close() == []


def test_collecting_sink_report_lines():
    sink = CollectingSink(min_level=Level.INFO)
    sink.emit(LogMessage.of(step=1, sim_time_ns=2, robot="r", text="kept"))
    sink.emit(LogMessage.of(step=1, sim_time_ns=2, robot="r", text="no", level=Level.DEBUG))
    assert sink.report_lines() == ["log: 1", "[INFO step 1] kept"]


def test_recording_sink_wraps_recorder_errors(tmp_path):
    path = tmp_path / "r.mcap"
    recorder = Recorder(
        path,
        metadata={
            "timestep": "0.002",
            "integrator": "Euler",
            "seed": "0",
            "model_sha256": "0" * 64,
            "control_modes": "{}",
        },
    )
    sink = RecordingSink(recorder)
    event = LogMessage.of(step=3, sim_time_ns=6, robot="r", text="late")
    sink.emit(event)
    recorder.close()
    with pytest.raises(SinkError, match="log at step 3"):
        sink.emit(event)
    assert sink.close().delivered == 1
