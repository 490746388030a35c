"""``/joint_command`` accepts what ``/joint_states`` lists: a client that echoes the joint
states back (the mimic follower ``finger_joint2`` included) is obeyed, an inconsistent value
for a joint it cannot command is warned about once, and ``/harness/get_state`` says which
joints are controllable."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from harness.models import LoadedRobot
from harness.session import Session
from tests.session.session_helpers import Client


def _statuses(client: Client) -> list[str]:
    return [f["msg"] for f in client.received if f.get("op") == "status"]


def test_echoed_joint_states_are_obeyed(
    demo_position: LoadedRobot, client_factory: Callable[[str], Client]
) -> None:
    with Session(demo_position, joint_states_hz=100) as session:
        client = client_factory(session.url)
        client.send({"op": "set_level", "level": "warning"})
        state = client.call("/harness/get_state")["values"]
        controllable = state["controllable_joints"]
        listed = state["joint_state"]["name"]
        assert "finger_joint2" in listed
        assert "finger_joint2" not in controllable
        assert set(controllable) < set(listed)

        echo = dict(state["joint_state"])
        position = list(echo["position"])
        position[listed.index("joint1")] = 0.4
        echo["position"] = position
        client.publish("/joint_command", echo)
        client.step(200)
        assert session.joint_positions()[session.sim.joint_names.index("joint1")] == (
            pytest.approx(0.4, abs=0.02)
        )
        assert not any("finger_joint2" in s for s in _statuses(client))  # consistent: silent

        # A follower value its leader does not give: ignored, with one warning.
        wrong = dict(echo)
        position = list(echo["position"])
        position[listed.index("finger_joint2")] = 0.03
        position[listed.index("finger_joint1")] = 0.0
        wrong["position"] = position
        client.publish("/joint_command", wrong)
        client.step(1)
        client.publish("/joint_command", wrong)
        client.step(1)
        warned = [s for s in _statuses(client) if "finger_joint2" in s]
        assert len(warned) == 1
        assert "not controllable (it mimics 'finger_joint1')" in warned[0]

        # A name the robot does not list is still refused.
        client.publish("/joint_command", {"name": ["elbow"], "position": [0.1]})
        client.step(1)
        assert any("unknown joint 'elbow'" in s for s in _statuses(client))
