"""Small worlds and robots for the camera tests (written for the harness tests): a robot
whose camera looks along +x at a wall 2 m ahead, and the pixels it sees."""

from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.models import load_robot
from harness.sensors import RobotMount, SensorSuite

W, H, HFOV = 64, 48, 1.0
EYE = 0.5  # m: the camera's height above the robot's base (which rests on the world origin)
WALL_X = 2.0  # m: the centre of the wall (0.1 m thick: its face is at 1.95 m)
FACE = WALL_X - 0.05

CAMERA: dict[str, Any] = {
    "name": "cam",
    "type": "rgbd",
    "parent": "base_link",
    "width": W,
    "height": H,
    "hfov": HFOV,
    "pose": [0, 0, EYE, 0, 0, 0],
    "near": 0.05,
    "far": 20.0,
}

ROBOT = """<?xml version="1.0"?>
<robot name="eye">
  <material name="marker_orange"><color rgba="1 0.45 0 1"/></material>
  <link name="base_link">
    <inertial><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
    <visual><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></visual>
  </link>
  <link name="spinner">
    <inertial><mass value="0.1"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="spin" type="continuous">
    <parent link="base_link"/><child link="spinner"/><axis xyz="0 0 1"/>
  </joint>
{links}</robot>
"""

MARKER = """  <link name="{name}">
    <inertial><mass value="0.1"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <visual><geometry><box size="0.05 0.4 0.3"/></geometry>{material}</visual>
  </link>
  <joint name="{name}_joint" type="fixed">
    <parent link="base_link"/><child link="{name}"/><origin xyz="1 {y} {z}"/>
  </joint>
"""

WORLD = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="wall_world">
{extra}    <model name="wall">
      <static>true</static>
      <pose>{wall_x} 0 1 0 0 0</pose>
      <link name="link">
        <collision name="collision"><geometry><box><size>0.1 8 2</size></box></geometry></collision>
        <visual name="visual"><geometry><box><size>0.1 8 2</size></box></geometry>
          {material}
        </visual>
      </link>
    </model>
  </world>
</sdf>
"""

POINT_LIGHT = """    <light type="point" name="bulb">
      <pose>1.6 0.6 0.5 0 0 0</pose>
      <diffuse>1 1 1 1</diffuse>
      <specular>0 0 0 1</specular>
      <attenuation><range>5</range><constant>0.2</constant><linear>0.5</linear>
        <quadratic>1</quadratic></attenuation>
    </light>
"""
RED = "<material><ambient>0.8 0 0 1</ambient><diffuse>0.9 0.05 0.05 1</diffuse></material>"
GAZEBO_BLUE = (
    "<material><script><uri>file://media/materials/scripts/gazebo.material</uri>"
    "<name>Gazebo/Blue</name></script></material>"
)


def world(folder: Path, material: str, extra: str = "", wall_x: float = WALL_X) -> Path:
    """A world with one static wall across +x whose visual has ``material``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "wall.world"
    path.write_text(WORLD.format(material=material, extra=extra, wall_x=wall_x))
    return path


def robot(
    folder: Path, markers: Sequence[tuple[str, float, float, str]] = (), gazebo: str = ""
) -> Path:
    """The camera robot, with marker links ``(name, y, z, material xml)`` 1 m ahead, and
    ``gazebo`` (raw ``<gazebo>`` elements)."""
    folder.mkdir(parents=True, exist_ok=True)
    links = "".join(
        MARKER.format(name=name, y=y, z=z, material=material) for name, y, z, material in markers
    )
    links += gazebo
    path = folder / "eye.urdf"
    path.write_text(ROBOT.format(links=links))
    return path


def view(
    urdf: Path, scene: Path | str, extra: str = "", camera: Mapping[str, Any] = CAMERA
) -> tuple[np.ndarray, np.ndarray, mujoco.MjModel]:
    """The RGB and depth images the robot's camera takes at the start, loaded as a session
    whose camera renders loads it (with its visuals), and the model."""
    loaded = load_robot(urdf, scene=scene, visuals=True)
    model = loaded.model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dt_ns = round(model.opt.timestep * 1e9)
    suite = SensorSuite.for_robots(model, [RobotMount("", "", {})], [camera], seed=0, dt_ns=dt_ns)
    assert suite is not None
    try:
        out = {d.output.topic: d.build() for d in suite.due(data, 0, 0)}
    finally:
        suite.close()
    rgb = np.frombuffer(out["/cam/image_raw"]["data"], np.uint8).reshape(H, W, 3)
    depth = np.frombuffer(out["/cam/depth/image_raw"]["data"], "<f4").reshape(H, W)
    return rgb, depth, model


def png(path: Path, rgb: tuple[int, int, int], size: int = 8) -> None:
    """A one-colour RGB PNG."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    rows = b"".join(b"\0" + bytes(rgb) * size for _ in range(size))
    header = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )
