"""The sensors room: sensor types map to kinds registered by their own modules; an unknown type
is one line naming it and the known ones; a plug-in sensor kind needs no core edit."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import pytest

from harness.sensors import (
    RobotMount,
    SensorSpec,
    SensorSuite,
    UnknownSensorType,
    known_types,
    register_kind,
    sensors_from_sdf,
)
from harness.sensors import registry as sensors_registry
from harness.sensors.base import F64, SensorTopic, View, quat_of
from harness.sensors.registry import Mounted, SensorKind
from harness.sensors.sdf_values import element_number
from tests.sensors.sensor_helpers import RIG


def test_an_unknown_sensor_type_is_one_line_naming_it_and_the_known_ones() -> None:
    with pytest.raises(UnknownSensorType) as info:
        SensorSpec.from_mapping({"name": "g", "type": "gps", "parent": "mount"}, "sensors[0]")
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith("sensor 'g' (sensors[0]): type 'gps' is not one of ")
    known = known_types()
    assert {"camera", "imu", "lidar", "force_torque", "contact", "ground_truth"} <= set(known)
    assert all(name in text for name in known)
    with pytest.raises(UnknownSensorType, match=r"^unknown sensor type 'sonar' \(known: camera"):
        sensors_registry.kind_of("sonar")


@pytest.fixture
def private_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Registrations made in the test are dropped after it."""
    known_types()
    monkeypatch.setattr(sensors_registry, "_KINDS", dict(sensors_registry._KINDS))
    monkeypatch.setattr(sensors_registry, "_GAZEBO", dict(sensors_registry._GAZEBO))


class _Altimeter:
    """A sensor kind from outside the room: the mount's height (``std_msgs/Float64``)."""

    def __init__(self, spec: SensorSpec, at: Mounted) -> None:
        self.spec = spec
        self.mount = at.mount
        self.frame_id = at.frame_id
        self.outputs = (SensorTopic("height", at.topics["height"], "std_msgs/msg/Float64"),)

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        return {"height": lambda: {"data": float(self.mount.world(view.data)[0][2])}}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        return [(self.frame_id, self.mount.position, quat_of(self.mount.rotation))]


SDF = b"""<sdf version="1.9"><model name="m"><link name="mount">
  <sensor name="alti" type="altimeter"><update_rate>25</update_rate>
    <altimeter><offset>1.5</offset></altimeter></sensor>
</link></model></sdf>"""


@pytest.mark.usefixtures("private_registry")
def test_a_registered_kind_is_declared_and_built_without_a_core_edit() -> None:
    assert sensors_from_sdf(SDF) == []  # an unimplemented Gazebo type is skipped
    register_kind(
        SensorKind(
            "altimeter",
            ("height",),
            10.0,
            _Altimeter,
            gazebo=("altimeter",),
            params=lambda el, where: {"noise_mean": element_number(el, "altimeter/offset", where)},
        )
    )
    (spec,) = sensors_from_sdf(SDF, "alti.sdf")
    assert (spec.type, spec.parent, spec.update_rate, spec.noise_mean) == (
        "altimeter",
        "mount",
        25.0,
        1.5,
    )
    assert dict(spec.topics) == {"height": "alti/height"}
    model = mujoco.MjModel.from_xml_path(str(RIG))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    suite = SensorSuite(model, [(spec, RobotMount("", "", {}))], seed=0, dt_ns=2_000_000)
    (due,) = suite.due(data, 0, 0)
    assert (due.output.topic, due.build()) == ("/alti/height", {"data": 1.0})
    assert suite.due(data, 1, 2_000_000) == []  # 25 Hz on a 500 Hz simulation: every 20 steps
    assert (
        SensorSpec.from_mapping({"name": "a", "type": "altimeter", "parent": "mount"}).update_rate
        == 10.0
    )
