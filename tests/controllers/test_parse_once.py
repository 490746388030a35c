"""A robot's model files are parsed once for its controllers and once for its sensors, not
again for every session or ``harness explore`` example of the same robot; a changed file is
parsed again, and what depends on the file system (a ``<parameters>`` file) is still looked
at every time."""

from __future__ import annotations

import uuid
from pathlib import Path

import pytest

import harness.controllers.gazebo_plugins as gazebo_plugins
import harness.models.files.xmlsafe as xmlsafe
import harness.sensors.declare as declare
from harness.controllers import ControllersWarning, default_controllers, robot_controllers
from harness.sensors import declared_in_sources

DATA = Path(__file__).resolve().parents[2] / "harness" / "models" / "data"
SENSORS = Path(__file__).resolve().parents[1] / "data" / "sensors" / "sensor_bot.urdf"


def _counting(monkeypatch: pytest.MonkeyPatch, module: object) -> list[str]:
    """Counts the parses behind ``module``'s robot file reads (``parse_xml_kept`` parses
    through ``harness.models.files.xmlsafe.parse_xml``)."""
    assert module.parse_xml_kept is xmlsafe.parse_xml_kept  # type: ignore[attr-defined]
    module = xmlsafe
    parsed: list[str] = []
    real = module.parse_xml

    def parse_xml(data: bytes, source: str) -> object:
        parsed.append(source)
        return real(data, source)

    monkeypatch.setattr(module, "parse_xml", parse_xml)
    return parsed


def _unique(data: bytes) -> bytes:
    """The file with a comment of its own (no earlier test's parse serves it)."""
    return data.replace(b"?>", f"?><!-- {uuid.uuid4()} -->".encode(), 1)


def test_controllers_parse_a_robot_file_once(monkeypatch: pytest.MonkeyPatch) -> None:
    parsed = _counting(monkeypatch, gazebo_plugins)
    urdf = _unique((DATA / "mobile_bot.urdf").read_bytes())
    default = default_controllers([], {})
    first = robot_controllers(default, {"model/mobile_bot.urdf": urdf})
    again = robot_controllers(default, {"model/mobile_bot.urdf": bytes(bytearray(urdf))})
    assert again == first
    assert parsed == ["model/mobile_bot.urdf"]
    changed = urdf.replace(b"</robot>", b"<!-- changed --></robot>")
    assert robot_controllers(default, {"model/mobile_bot.urdf": changed}) == first
    assert parsed == ["model/mobile_bot.urdf"] * 2


def test_a_missing_parameters_file_still_warns_every_time(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    parsed = _counting(monkeypatch, gazebo_plugins)
    urdf = _unique(
        b'<?xml version="1.0"?><robot name="r"><link name="base"/><gazebo>'
        b'<plugin filename="libgz_ros2_control-system.so" name="gz_ros2_control">'
        b"<parameters>/nonexistent/controllers.yaml</parameters></plugin></gazebo></robot>"
    )
    default = default_controllers([], {})
    for _ in range(2):
        with pytest.warns(ControllersWarning, match="is no file"):
            assert robot_controllers(default, {"model/r.urdf": urdf}) == default
    assert len(parsed) == 1


def test_sensors_parse_a_robot_file_once(monkeypatch: pytest.MonkeyPatch) -> None:
    parsed = _counting(monkeypatch, declare)
    urdf = _unique(SENSORS.read_bytes())
    first = declared_in_sources({"model/sensor_bot.urdf": urdf})
    assert first
    assert declared_in_sources({"model/sensor_bot.urdf": urdf}) == first
    assert parsed == ["sensor_bot.urdf"]
