"""Drive a TurtleBot3 on a lockstep bridge and measure its wheel odometry against the truth.

Used by the tests of every entry point (in process, and as the client of ``harness run``:
``python drive.py`` with ``HARNESS_ROSBRIDGE_URL`` set exits 0 when odometry matches)."""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script by harness run: the harness is importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from harness.testing import connect

MODELS = Path(__file__).resolve().parents[2] / "data" / "worlds" / "turtlebot3" / "models"
SPEED = 0.2  # m/s
DRIVE_S = 5.0
REST_S = 0.5
TOLERANCE = 0.02  # odometry vs ground truth, of the distance travelled
ODOM = "nav_msgs/msg/Odometry"


def model(name: str) -> Path:
    """The vendored ``turtlebot3_<name>`` model.sdf."""
    return MODELS / f"turtlebot3_{name}" / "model.sdf"


@dataclass(frozen=True)
class Travel:
    """How far the robot went by its wheel odometry and in truth, and the odometry's rate."""

    odom: float
    true: float
    odom_lateral: float
    odom_messages: int
    imu_messages: int

    def check(self) -> None:
        """Raise AssertionError unless odometry and truth agree to :data:`TOLERANCE`."""
        assert self.true > 0.9 * SPEED * DRIVE_S, f"the robot barely moved: {self}"
        assert abs(self.odom - self.true) <= TOLERANCE * self.true, self
        assert abs(self.odom_lateral) <= TOLERANCE * self.true, self


def _xy(msg: dict) -> tuple[float, float]:  # type: ignore[type-arg]
    p = msg["pose"]["pose"]["position"]
    return float(p["x"]), float(p["y"])


def _run(client: Any, steps: int) -> None:
    """``steps`` steps, a few at a time (a camera's frames take wall time)."""
    for _ in range(steps // 100):
        client.step(100)
    client.step(steps % 100)
    client.sync()


def drive(url: str) -> Travel:
    """Straight at :data:`SPEED` for :data:`DRIVE_S`, then stop: odometry vs ground truth."""
    with connect(url) as client:
        start = client.step(0)
        dt = (client.step(1) - start) / 1e9
        odom = client.subscribe("/odom", ODOM)
        truth = client.subscribe("/ground_truth/odom", ODOM)
        imu = client.subscribe("/imu", "sensor_msgs/msg/Imu")
        client.sync()
        _run(client, round(0.1 / dt))
        assert odom.latest is not None, "no /odom"
        assert truth.latest is not None, "no /ground_truth/odom"
        (ox, oy), (tx, ty) = _xy(odom.latest), _xy(truth.latest)
        count, imu_count = len(odom.messages), len(imu.messages)
        twist = {
            "linear": {"x": SPEED, "y": 0.0, "z": 0.0},
            "angular": {"x": 0.0, "y": 0.0, "z": 0.0},
        }
        client.publish("/cmd_vel", "geometry_msgs/msg/Twist", twist)
        client.sync()
        _run(client, round(DRIVE_S / dt))
        twist["linear"]["x"] = 0.0
        client.publish("/cmd_vel", "geometry_msgs/msg/Twist", twist)
        client.sync()
        _run(client, round(REST_S / dt))
        (ox2, oy2), (tx2, ty2) = _xy(odom.latest), _xy(truth.latest)
        return Travel(
            odom=math.hypot(ox2 - ox, oy2 - oy),
            true=math.hypot(tx2 - tx, ty2 - ty),
            odom_lateral=oy2 - oy,
            odom_messages=len(odom.messages) - count,
            imu_messages=len(imu.messages) - imu_count,
        )


if __name__ == "__main__":
    travel = drive(os.environ["HARNESS_ROSBRIDGE_URL"])
    print(travel)
    travel.check()
