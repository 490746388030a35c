"""Paths the ROS 2 tests share."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ARM_NODE = ROOT / "examples" / "ros2_node" / "arm_node.py"
