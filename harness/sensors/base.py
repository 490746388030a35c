"""What every sensor kind shares: where it is mounted (:class:`Mount`), the state it reads
(:class:`View`), its outputs and the :class:`Sensor` protocol."""

from __future__ import annotations

import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sensors.errors import SensorConfigError
from harness.sensors.registry import Mount
from harness.sensors.spec import SensorSpec

__all__ = [
    "Mount",
    "Sensor",
    "SensorTopic",
    "View",
    "cross",
    "find_object",
    "mount_of",
    "noise_rng",
    "quat_of",
    "rpy_matrix",
]

F64 = npt.NDArray[np.float64]

# Sensor axes (x forward, y left, z up) in an MJCF camera's axes (looks along -z, y up).
_CAMERA_TO_SENSOR: F64 = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> F64:
    """The rotation of URDF/SDF ``rpy`` (fixed axes x, y, z: Rz(yaw) Ry(pitch) Rx(roll))."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def cross(a: F64, b: F64) -> F64:
    """``a x b`` of two 3-vectors (``np.cross`` costs ~20x more on small vectors)."""
    out = np.empty(3)
    mujoco.mju_cross(
        out, np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    )
    return out


def quat_of(rotation: F64) -> F64:
    """A rotation matrix as a unit quaternion w-x-y-z."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).reshape(9))
    return quat


def find_object(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str) -> int:
    """The id of the ``obj`` named ``name`` (or ending in ``/name``, ``::name``), else -1."""
    index = int(mujoco.mj_name2id(model, obj, name))
    if index >= 0:
        return index
    count = {
        mujoco.mjtObj.mjOBJ_BODY: model.nbody,
        mujoco.mjtObj.mjOBJ_JOINT: model.njnt,
        mujoco.mjtObj.mjOBJ_SITE: model.nsite,
        mujoco.mjtObj.mjOBJ_CAMERA: model.ncam,
        mujoco.mjtObj.mjOBJ_GEOM: model.ngeom,
    }[obj]
    for i in range(count):  # scoped names (SDF nested models): match the last part
        full = mujoco.mj_id2name(model, obj, i) or ""
        if full.endswith(("/" + name, "::" + name)):
            return i
    return -1


def mount_of(model: mujoco.MjModel, spec: SensorSpec, prefix: str = "") -> Mount:
    """Where ``spec`` sits in ``model`` (names get the robot's ``prefix``)."""
    where = f"sensor {spec.name!r}" + (f" ({spec.source})" if spec.source else "")
    offset = np.array(spec.pose[:3])
    rotation = rpy_matrix(*spec.pose[3:])
    if spec.camera or spec.site:
        obj = mujoco.mjtObj.mjOBJ_CAMERA if spec.camera else mujoco.mjtObj.mjOBJ_SITE
        name = prefix + (spec.camera or spec.site)
        index = find_object(model, obj, name)
        if index < 0:
            kind = "camera" if spec.camera else "site"
            raise SensorConfigError(f"{where}: the model has no {kind} {name!r}")
        if spec.camera:
            body = int(model.cam_bodyid[index])
            local_pos, local_quat = model.cam_pos[index], model.cam_quat[index]
        else:
            body = int(model.site_bodyid[index])
            local_pos, local_quat = model.site_pos[index], model.site_quat[index]
        local = np.zeros(9)
        mujoco.mju_quat2Mat(local, local_quat)
        local_rot = local.reshape(3, 3)
        if spec.camera:
            local_rot = local_rot @ _CAMERA_TO_SENSOR
        return Mount(
            body,
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body{body}",
            local_pos + local_rot @ offset,
            local_rot @ rotation,
        )
    link = spec.parent
    if spec.joint and not link:
        joint = find_object(model, mujoco.mjtObj.mjOBJ_JOINT, prefix + spec.joint)
        if joint < 0:
            raise SensorConfigError(f"{where}: the model has no joint {prefix + spec.joint!r}")
        body = int(model.jnt_bodyid[joint])
    else:
        body = find_object(model, mujoco.mjtObj.mjOBJ_BODY, prefix + link)
    if body < 0:
        raise SensorConfigError(
            f"{where}: the model has no link {prefix + link!r} (fused away or misspelled)"
        )
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body{body}"
    return Mount(body, name, offset, rotation)


def noise_rng(seed: int, name: str, step: int) -> np.random.Generator:
    """The noise generator of sensor ``name`` at ``step``: a function of the session seed, the
    sensor and the step only, so noise does not depend on who listened before."""
    return np.random.Generator(
        np.random.PCG64([seed & 0xFFFFFFFF, zlib.crc32(name.encode()), step])
    )


@dataclass
class View:
    """The state a sensor reads at a step: ``data`` holds the current state with positions,
    velocities, accelerations and (after :meth:`forces`) interaction forces computed."""

    model: mujoco.MjModel
    data: mujoco.MjData
    step: int
    sim_time_ns: int
    seed: int
    forces_done: bool = False

    def forces(self) -> None:
        """Compute body accelerations and interaction forces (``cacc``, ``cfrc_int``)."""
        if not self.forces_done:
            mujoco.mj_rnePostConstraint(self.model, self.data)
            self.forces_done = True


@dataclass(frozen=True)
class SensorTopic:
    """One topic of a sensor: ``key`` (one of its kind's outputs,
    :attr:`~harness.sensors.registry.SensorKind.outputs`), resolved ``topic``, message type,
    and whether it goes into the recording."""

    key: str
    topic: str
    msgtype: str
    record: bool = True


class Sensor(Protocol):
    """One sensor kind's reader. A kind that feeds controllers also has ``state_interfaces``
    (interface names without the sensor's, e.g. ``orientation.x``) and
    ``interface_values(view)`` (their values at a step, in that order): see
    :meth:`harness.sensors.SensorSuite.interfaces`."""

    spec: SensorSpec
    outputs: tuple[SensorTopic, ...]
    frame_id: str
    """The frame its messages are stamped in."""

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """This step's message builders by output key (called only for messages someone
        records or listens to)."""
        ...

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """``(child frame, xyz, quat w-x-y-z)`` of the sensor frames in the mount link."""
        ...
