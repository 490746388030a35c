"""Scripted MuJoCo scenes for the logger tests: raw mj_step + extract_contacts, no session."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pytest

from harness.events import EventHub, StepContext
from harness.sim.contacts import extract_contacts

DATA = Path(__file__).resolve().parents[1] / "data" / "events"

Script = Callable[[int, mujoco.MjData], None]


class SceneRun:
    """Load a scene from tests/data/events and step it, feeding a hub after every step."""

    def model(self, name: str) -> mujoco.MjModel:
        return mujoco.MjModel.from_xml_path(str(DATA / name))

    def run(
        self,
        model: mujoco.MjModel,
        hub: EventHub,
        steps: int,
        script: Script | None = None,
        robot: str = "robot",
        finish: bool = True,
    ) -> str:
        """Steps 1..steps (step index and sim time as harness.sim.Simulation counts them);
        returns the SHA-256 of the integration state after every step."""
        data = mujoco.MjData(model)
        dt_ns = round(model.opt.timestep * 1e9)
        size = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION)
        state = np.zeros(size)
        digest = hashlib.sha256()
        ctx = None
        for k in range(steps):
            if script is not None:
                script(k, data)
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            digest.update(state.tobytes())
            ctx = StepContext(
                k + 1, (k + 1) * dt_ns, model, data, extract_contacts(model, data), robot
            )
            hub.observe(ctx)
        if finish and ctx is not None:
            hub.finish(ctx)
        return digest.hexdigest()


@pytest.fixture
def scene() -> SceneRun:
    return SceneRun()


def pusher_script(peak_k: int, x0: float = 0.0005, v_step: float = 0.001) -> Script:
    """Kinematic slide: x_k = x0 + v_step * min(k, 2 * peak_k - k), qvel 0."""

    def script(k: int, data: mujoco.MjData) -> None:
        data.qpos[0] = x0 + v_step * min(k, 2 * peak_k - k)
        data.qvel[0] = 0.0

    return script


@pytest.fixture
def pusher() -> Callable[..., Script]:
    return pusher_script
