"""Each sensor kind's own options record: a mapping's flat keys split by the kind, a key of
another kind refused in one line, each record validating its fields, and the recorded sensor
metadata (:meth:`SensorSpec.to_json`, format v1) unchanged."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from harness.recording import Recording
from harness.scenario import Scenario, ScenarioError
from harness.sensors import (
    METADATA_RECORD,
    CameraOptions,
    ContactOptions,
    ForceTorqueOptions,
    GroundTruthOptions,
    ImuOptions,
    LidarOptions,
    SensorConfigError,
    SensorOptions,
    SensorSpec,
    kind_of,
    known_types,
)
from harness.session import Session
from tests.sensors.sensor_helpers import RIG

CAMERA_OPTIONS = "width, height, hfov, near, far, record"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (
            {"name": "x", "type": "camera", "parent": "a", "samples": 10},
            f"sensor 'x' (robot.yaml): 'samples' is not an option of a camera sensor "
            f"(its options: {CAMERA_OPTIONS})",
        ),
        (
            {"name": "x", "type": "lidar", "parent": "a", "width": 64},
            "sensor 'x' (robot.yaml): 'width' is not an option of a lidar sensor (its options: "
            "samples, min_angle, max_angle, vertical_samples, vertical_min_angle, "
            "vertical_max_angle, range_min, range_max, range_resolution)",
        ),
        (
            {"name": "x", "type": "imu", "parent": "a", "collision": "g"},
            "sensor 'x' (robot.yaml): 'collision' is not an option of a imu sensor (its options: "
            "accel_noise_mean, accel_noise_stddev)",
        ),
        (
            {"name": "x", "type": "contact", "parent": "a", "ft_frame": "parent"},
            "sensor 'x' (robot.yaml): 'ft_frame' is not an option of a contact sensor (its "
            "options: collision)",
        ),
        (
            {"name": "x", "type": "ground_truth", "parent": "a", "hfov": 1.0},
            "sensor 'x' (robot.yaml): 'hfov' is not an option of a ground_truth sensor (its "
            "options: none)",
        ),
    ],
)
def test_an_option_of_another_kind_is_refused_in_one_line(value: dict, message: str) -> None:
    """main took any kind's key on any sensor and ignored it silently."""
    with pytest.raises(SensorConfigError) as info:
        SensorSpec.from_mapping(value, "robot.yaml")
    assert str(info.value) == message


def test_a_scenario_sensor_with_another_kinds_option_is_a_scenario_problem() -> None:
    sensors = [{"name": "cam", "type": "camera", "parent": "mount", "range_max": 5.0}]
    with pytest.raises(ScenarioError) as info:
        Scenario.from_mapping(
            {"name": "s", "robots": [{"robot": str(RIG), "name": "rig"}], "sensors": sensors}
        )
    text = str(info.value)
    assert "sensors[0]" in text
    assert "'range_max' is not an option of a camera sensor" in text


def test_flat_keys_split_by_kind_into_its_options_record() -> None:
    lidar = SensorSpec.from_mapping(
        {"name": "scan", "type": "lidar", "parent": "a", "samples": 90, "noise_stddev": 0.01}
    )
    assert lidar.options == LidarOptions(samples=90)
    assert lidar.noise_stddev == 0.01  # shared by the kinds that draw noise: a spec field
    assert lidar.options_as(LidarOptions).samples == 90
    with pytest.raises(TypeError, match="not CameraOptions"):
        lidar.options_as(CameraOptions)
    imu = SensorSpec(name="imu", type="imu", parent="a")
    assert imu.options == ImuOptions()  # the kind's defaults when none are given
    with pytest.raises(SensorConfigError, match="options are a ImuOptions, not a LidarOptions"):
        SensorSpec(name="imu", type="imu", parent="a", options=LidarOptions())


def test_every_kind_registers_its_own_options_record() -> None:
    records = {t: kind_of(t).options for t in known_types()}
    assert records == {
        "camera": CameraOptions,
        "contact": ContactOptions,
        "depth": CameraOptions,
        "force_torque": ForceTorqueOptions,
        "ground_truth": GroundTruthOptions,
        "imu": ImuOptions,
        "lidar": LidarOptions,
        "rgbd": CameraOptions,
    }
    for record in records.values():
        assert issubclass(record, SensorOptions)
        with pytest.raises(AttributeError):  # frozen
            record().__setattr__("x", 1)


@pytest.mark.parametrize(
    ("record", "fields", "message"),
    [
        (CameraOptions, {"width": 0}, "width must be an integer >= 1, not 0"),
        (CameraOptions, {"height": 2.5}, "height must be an integer >= 1, not 2.5"),
        (CameraOptions, {"hfov": -1}, "hfov must be a number > 0, not -1"),
        (CameraOptions, {"hfov": 3.2}, "hfov must be below pi rad, not 3.2"),
        (CameraOptions, {"near": 5, "far": 1}, "near clip 5 must be below far 1"),
        (CameraOptions, {"record": "jpeg"}, "record must be 'raw' or 'compressed'"),
        (LidarOptions, {"samples": 0}, "samples must be an integer >= 1, not 0"),
        (LidarOptions, {"vertical_samples": True}, "vertical_samples must be an integer >= 1"),
        (LidarOptions, {"range_max": math.inf}, "range_max must be a number > 0, not inf"),
        (LidarOptions, {"range_resolution": -0.1}, "range_resolution must be a number >= 0"),
        (LidarOptions, {"min_angle": math.nan}, "min_angle must be a finite number, not nan"),
        (LidarOptions, {"range_min": 40.0}, "range_min 40.0 must be below range_max 30.0"),
        (LidarOptions, {"min_angle": 1.0, "max_angle": 0.5}, "a min angle is above its max"),
        (ImuOptions, {"accel_noise_stddev": -1}, "accel_noise_stddev must be a number >= 0"),
        (ImuOptions, {"accel_noise_mean": math.nan}, "accel_noise_mean must be a finite number"),
        (ForceTorqueOptions, {"ft_frame": "world"}, "ft_frame must be child, parent or sensor"),
        (ForceTorqueOptions, {"ft_direction": "up"}, "ft_direction must be child_to_parent"),
        (ContactOptions, {"collision": 3}, "collision must be a geom name, not 3"),
    ],
)
def test_each_options_record_validates_its_fields(
    record: type[SensorOptions], fields: dict[str, Any], message: str
) -> None:
    with pytest.raises(SensorConfigError) as info:
        record(**fields)
    assert str(info.value).startswith(message)
    assert "\n" not in str(info.value)
    # through a spec, the message names the sensor and where it was declared
    kind = next(t for t in known_types() if kind_of(t).options is record)
    with pytest.raises(SensorConfigError) as info:
        SensorSpec.from_mapping({"name": "s", "type": kind, "parent": "a", **fields}, "f.yaml")
    assert str(info.value).startswith(f"sensor 's' (f.yaml): {message}")


# SensorSpec.from_mapping(case).to_json() of these, captured from main at 3bf02f1 (the flat
# SensorSpec): the recorded sensor metadata must stay identical.
_V1_COMMON: dict[str, Any] = {
    "pose": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "joint": "", "camera": "", "site": "", "topic": "",
    "topics": {}, "frame_id": "", "width": 320, "height": 240, "hfov": 1.047, "near": 0.05,
    "far": 100.0, "record": "raw", "samples": 360, "min_angle": -3.141592653589793,
    "max_angle": 3.141592653589793, "vertical_samples": 1, "vertical_min_angle": 0.0,
    "vertical_max_angle": 0.0, "range_min": 0.1, "range_max": 30.0, "range_resolution": 0.0,
    "noise_mean": 0.0, "noise_stddev": 0.0, "accel_noise_mean": None,
    "accel_noise_stddev": None, "ft_frame": "child", "ft_direction": "child_to_parent",
    "collision": "", "namespace": "", "source": "sensors",
}  # fmt: skip
_KEY_ORDER = [
    "name", "type", "parent", "pose", "joint", "camera", "site", "update_rate", "topic",
    "topics", "frame_id", "width", "height", "hfov", "near", "far", "record", "samples",
    "min_angle", "max_angle", "vertical_samples", "vertical_min_angle", "vertical_max_angle",
    "range_min", "range_max", "range_resolution", "noise_mean", "noise_stddev",
    "accel_noise_mean", "accel_noise_stddev", "ft_frame", "ft_direction", "collision",
    "namespace", "source",
]  # fmt: skip
_MAIN_TO_JSON: list[tuple[dict[str, Any], dict[str, Any]]] = [
    (
        {"name": "cam", "type": "camera", "parent": "link1", "width": 64, "height": 48,
         "hfov": 0.9, "record": "compressed", "noise_stddev": 0.01},
        {"name": "cam", "type": "camera", "parent": "link1", "update_rate": 10.0, "width": 64,
         "height": 48, "hfov": 0.9, "record": "compressed", "noise_stddev": 0.01},
    ),
    (
        {"name": "dep", "type": "depth", "parent": "link1", "near": 0.1, "far": 20.0},
        {"name": "dep", "type": "depth", "parent": "link1", "update_rate": 10.0, "near": 0.1,
         "far": 20.0},
    ),
    (
        {"name": "rgbd", "type": "rgbd", "camera": "cam0"},
        {"name": "rgbd", "type": "rgbd", "parent": "", "camera": "cam0", "update_rate": 10.0},
    ),
    (
        {"name": "scan", "type": "lidar", "parent": "base", "samples": 90, "min_angle": -1.5,
         "max_angle": 1.5, "range_max": 12.0, "range_resolution": 0.01,
         "pose": [0, 0, 0.2, 0, 0, 0], "topics": {"scan": "/s"}},
        {"name": "scan", "type": "lidar", "parent": "base", "pose": [0.0, 0.0, 0.2, 0.0, 0.0, 0.0],
         "update_rate": 10.0, "topics": {"scan": "/s"}, "samples": 90, "min_angle": -1.5,
         "max_angle": 1.5, "range_max": 12.0, "range_resolution": 0.01},
    ),
    (
        {"name": "imu", "type": "imu", "site": "imu_site", "noise_stddev": 0.002,
         "accel_noise_stddev": 0.02, "update_rate": 200},
        {"name": "imu", "type": "imu", "parent": "", "site": "imu_site", "update_rate": 200,
         "noise_stddev": 0.002, "accel_noise_stddev": 0.02},
    ),
    (
        {"name": "ft", "type": "force_torque", "joint": "j1", "ft_frame": "sensor",
         "ft_direction": "parent_to_child"},
        {"name": "ft", "type": "force_torque", "parent": "", "joint": "j1", "update_rate": 100.0,
         "ft_frame": "sensor", "ft_direction": "parent_to_child"},
    ),
    (
        {"name": "bump", "type": "contact", "parent": "link2", "collision": "geom2",
         "namespace": "r1", "source": "scenario"},
        {"name": "bump", "type": "contact", "parent": "link2", "update_rate": 100.0,
         "collision": "geom2", "namespace": "r1", "source": "scenario"},
    ),
    (
        {"name": "gt", "type": "ground_truth", "parent": "base", "frame_id": "world",
         "topic": "odom"},
        {"name": "gt", "type": "ground_truth", "parent": "base", "update_rate": 50.0,
         "topic": "odom", "frame_id": "world"},
    ),
]  # fmt: skip


@pytest.mark.parametrize(("given", "changed"), _MAIN_TO_JSON, ids=lambda v: str(v.get("type")))
def test_to_json_of_each_kind_is_mains(given: dict[str, Any], changed: dict[str, Any]) -> None:
    expected = {**_V1_COMMON, **changed}
    spec = SensorSpec.from_mapping(given)
    out = spec.to_json()
    assert out == expected
    assert list(out) == _KEY_ORDER  # the same keys in the same order
    assert [type(v) for v in out.values()] == [type(expected[k]) for k in out]
    # and the recorded record reads back as the same spec (old recordings' metadata too)
    assert SensorSpec.from_json(expected) == spec
    assert SensorSpec.from_mapping(expected) == spec  # as Session(sensors=[spec]) passes it


def test_a_session_given_specs_records_their_v1_metadata(tmp_path: Path) -> None:
    """``Session(sensors=[SensorSpec])`` hands the session the spec's recorded record; an
    IMU's record carries a camera's and a lidar's keys at their defaults, which must not be
    refused as another kind's options."""
    specs = [
        SensorSpec.make(name="imu", type="imu", parent="mount", accel_noise_stddev=0.5),
        SensorSpec.make(name="scan", type="lidar", parent="mount", samples=8),
    ]
    path = tmp_path / "specs.mcap"
    with Session(RIG, record_to=path, sensors=specs) as session:
        session.step(2)
    with Recording(path) as rec:
        meta = rec.all_metadata[METADATA_RECORD]
    recorded = json.loads(meta["sensors"])
    assert [r["name"] for r in recorded] == ["imu", "scan"]
    assert [SensorSpec.from_json(r).options for r in recorded] == [s.options for s in specs]
    assert (recorded[0]["accel_noise_stddev"], recorded[0]["samples"]) == (0.5, 360)
