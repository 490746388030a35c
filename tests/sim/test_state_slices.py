"""``qpos_qvel_slices``: where qpos and qvel lie in a captured state (what the recorder's state
slot copies them from)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from harness.sim.state import STATE_SPEC, qpos_qvel_slices

# a free body (nq 7, nv 6), a ball joint (4, 3), a hinge with an activation actuator
_XML = """
<mujoco>
  <worldbody>
    <body name="floating"><freejoint/><geom size="0.1"/></body>
    <body name="arm" pos="1 0 1">
      <joint name="ball" type="ball"/><geom type="capsule" size="0.1" fromto="0 0 0 0 0 -0.5"/>
      <body pos="0 0 -0.5"><joint name="hinge" axis="0 1 0"/><geom size="0.05"/></body>
    </body>
  </worldbody>
  <actuator><general joint="hinge" dyntype="filter" dynprm="0.1"/></actuator>
</mujoco>
"""


@pytest.mark.parametrize("xml", [_XML, "<mujoco><worldbody/></mujoco>"])
def test_the_slices_are_qpos_and_qvel_of_the_state(xml: str) -> None:
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    data.qpos[:] = rng.standard_normal(model.nq)
    data.qvel[:] = rng.standard_normal(model.nv)
    data.act[:] = rng.standard_normal(model.na)
    state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    qpos, qvel = qpos_qvel_slices(model)
    np.testing.assert_array_equal(state[qpos], data.qpos)
    np.testing.assert_array_equal(state[qvel], data.qvel)
