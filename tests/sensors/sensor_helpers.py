"""Paths of the sensor tests' data."""

from __future__ import annotations

from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "data" / "sensors"
RIG = DATA / "sensor_rig.xml"
