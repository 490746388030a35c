"""IMU, force-torque and contact sensors on the rig (a 2 kg mass hangs below the wrist joint)."""

from __future__ import annotations

import math

import numpy as np
import pytest

G = 9.81


def _vec(v: dict) -> np.ndarray:
    return np.array([v["x"], v["y"], v["z"]])


def test_imu_at_rest_reads_gravity_on_its_up_axis(rig) -> None:
    out = rig(
        [
            {"name": "imu", "type": "imu", "parent": "mount"},
            {
                "name": "rolled",
                "type": "imu",
                "parent": "mount",
                "pose": [0, 0, 0, math.pi / 2, 0, 0],
            },
        ]
    ).read()
    imu = out["/imu/imu"]
    assert _vec(imu["linear_acceleration"]) == pytest.approx([0, 0, G], abs=1e-9)
    assert _vec(imu["angular_velocity"]) == pytest.approx([0, 0, 0], abs=1e-12)
    assert imu["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    # rolled +90 deg about x: the sensor's y axis points up
    rolled = out["/rolled/imu"]
    assert _vec(rolled["linear_acceleration"]) == pytest.approx([0, G, 0], abs=1e-9)


def test_imu_on_a_site_with_noise_is_seeded(rig) -> None:
    sensor = {"name": "imu", "type": "imu", "site": "imu_site", "noise_stddev": 0.1}
    a = rig([sensor], seed=1).read(5)["/imu/imu"]
    b = rig([sensor], seed=1).read(5)["/imu/imu"]
    assert a == b
    assert _vec(a["linear_acceleration"])[2] != G
    assert a["linear_acceleration_covariance"][0] == pytest.approx(0.01)


def test_force_torque_under_a_hanging_mass_reads_its_weight(rig) -> None:
    r = rig(
        [
            {"name": "ft", "type": "force_torque", "joint": "wrist"},
            {"name": "ft_up", "type": "force_torque", "joint": "wrist",
             "ft_direction": "parent_to_child"},
        ]
    )  # fmt: skip
    out = r.read()
    force = _vec(out["/ft/wrench"]["wrench"]["force"])
    assert force[2] == pytest.approx(-2.0 * G, rel=0.01)  # the child pulls its parent down
    assert abs(force[0]) < 1e-6
    assert abs(force[1]) < 1e-6
    assert _vec(out["/ft_up/wrench"]["wrench"]["force"])[2] == pytest.approx(2.0 * G, rel=0.01)
    assert out["/ft/wrench"]["header"]["frame_id"] == "ft"


def test_contact_sensor_reports_what_touches_its_link(rig) -> None:
    r = rig([{"name": "touch", "type": "contact", "parent": "weight"}])
    assert r.read()["/touch/contacts"]["states"] == []
    r.data.qpos[r.model.joint("swing").qposadr[0]] = math.pi / 2  # the weight up on the stop
    states = r.read(5)["/touch/contacts"]["states"]
    assert states, "expected the arm to touch the wall"
    assert {s["collision1_name"] for s in states} == {"weight_geom"}
    assert {s["collision2_name"] for s in states} == {"stop"}
    assert all(s["depths"][0] >= 0 for s in states)


def test_imu_gyro_and_accelerometer_noise_are_separate(rig) -> None:
    sensor = {"name": "imu", "type": "imu", "parent": "mount", "noise_stddev": 0.01,
              "accel_noise_mean": 0.2, "accel_noise_stddev": 0.5}  # fmt: skip
    r = rig([sensor], seed=2)
    gyro, accel = [], []
    for k in range(200):
        imu = r.read(5 * k)["/imu/imu"]
        gyro.append(_vec(imu["angular_velocity"]))
        accel.append(_vec(imu["linear_acceleration"]) - [0, 0, G])
    assert np.std(gyro) == pytest.approx(0.01, rel=0.15)
    assert np.std(accel) == pytest.approx(0.5, rel=0.15)
    assert np.mean(accel) == pytest.approx(0.2, abs=0.08)
    assert imu["angular_velocity_covariance"][0] == pytest.approx(0.01**2)
    assert imu["linear_acceleration_covariance"][0] == pytest.approx(0.25)


def test_gazebo_imu_noise_per_quantity_is_read() -> None:
    from harness.sensors import ImuOptions, sensors_from_sdf

    sdf = b"""<sdf version="1.9"><model name="m"><link name="l">
      <sensor name="imu" type="imu"><imu>
        <angular_velocity><x><noise type="gaussian">
          <mean>0</mean><stddev>0.0002</stddev>
        </noise></x></angular_velocity>
        <linear_acceleration><x><noise type="gaussian">
          <mean>0.1</mean><stddev>0.017</stddev>
        </noise></x></linear_acceleration>
      </imu></sensor></link></model></sdf>"""
    (imu,) = sensors_from_sdf(sdf)
    assert (imu.noise_mean, imu.noise_stddev) == (0.0, 0.0002)
    assert imu.options == ImuOptions(accel_noise_mean=0.1, accel_noise_stddev=0.017)
