"""A scenario object's orientation reaches the generated scene as URDF roll-pitch-yaw."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from harness.scenario import Scenario
from harness.scenario.world import scene_for

TWO_LINK = Path(__file__).parents[1] / "data" / "scenario" / "robots" / "two_link.urdf"


def test_object_orientation_is_fixed_axis_roll_pitch_yaw(tmp_path):
    rpy = [0.3, -0.2, 1.1]
    scenario = Scenario.from_mapping(
        {
            "robots": [{"robot": str(TWO_LINK)}],
            "environment": {"map": "empty"},
            "objects": [
                {
                    "name": "crate",
                    "shape": "box",
                    "size": [0.05, 0.05, 0.05],
                    "position": [0.3, 0.1, 1.0],
                    "orientation": rpy,
                }
            ],
        }
    )
    model = mujoco.MjModel.from_xml_path(str(scene_for(scenario, tmp_path)))
    expected = np.zeros(4)
    # Independent oracle: MuJoCo's own Euler conversion, extrinsic x then y then z.
    mujoco.mju_euler2Quat(expected, np.array(rpy), "XYZ")
    crate = model.body("crate")
    np.testing.assert_allclose(crate.pos, [0.3, 0.1, 1.0])
    np.testing.assert_allclose(crate.quat, expected, atol=1e-6)  # XML keeps ~7 digits
