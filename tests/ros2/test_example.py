"""The example robot project (examples/ros2_node) runs its own suite: its node on DDS and
through rosbridge-server-rs."""

from __future__ import annotations

import subprocess
import sys

import pytest

from harness.ros2 import Ros2Install
from tests.ros2.ros2_paths import ROOT


def _plugin_args() -> tuple[str, ...]:
    from importlib.metadata import entry_points

    installed = any(ep.name == "harness" for ep in entry_points(group="pytest11"))
    return () if installed else ("-p", "harness.pytest_plugin")


@pytest.mark.slow
def test_ros2_node_example_suite_passes(ros2: Ros2Install, tmp_path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "examples/ros2_node", "-q", "-p", "no:cacheprovider",
         f"--harness-record-dir={tmp_path}", *_plugin_args()],
        cwd=ROOT, capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "2 passed" in done.stdout, done.stdout[-2000:]
