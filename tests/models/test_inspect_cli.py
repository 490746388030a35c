"""``harness inspect-model``: the JSON contract and the human table."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yourdfpy

from harness.cli import main
from harness.models import DEMO_URDF, Pose

LIMIT_KEYS = {"lower", "upper", "velocity", "effort"}


def _inspect(capsys, *args: str) -> str:
    assert main(["inspect-model", *args]) == 0
    return capsys.readouterr().out


def _check_contract(doc: dict) -> None:
    assert set(doc) == {"model", "links", "joints", "frames"}
    for link in doc["links"]:
        assert set(link) == {"name", "pose"}
        assert len(link["pose"]) == 7
        assert np.linalg.norm(link["pose"][3:]) == pytest.approx(1.0, abs=1e-12)
    for joint in doc["joints"]:
        assert set(joint) == {"name", "type", "parent", "child", "pose", "axis", "limits"}
        assert set(joint["limits"]) == LIMIT_KEYS
        assert len(joint["axis"]) == 3


@pytest.mark.parametrize("source", ["demo", "rotated_chain"])
def test_json_contract_matches_yourdfpy(capsys, data_dir, source):
    path = DEMO_URDF if source == "demo" else data_dir / "rotated_chain.urdf"
    doc = json.loads(_inspect(capsys, "demo" if source == "demo" else str(path), "--json"))
    _check_contract(doc)
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    urdf.update_cfg(np.zeros(len(urdf.actuated_joint_names)))
    assert doc["model"] == urdf.robot.name
    assert [link["name"] for link in doc["links"]] == [link.name for link in urdf.robot.links]
    for link in doc["links"]:
        expected = urdf.get_transform(frame_to=link["name"], frame_from=urdf.base_link)
        got = Pose(tuple(link["pose"][:3]), tuple(link["pose"][3:]))
        assert np.allclose(got.matrix(), expected, atol=1e-12), link["name"]
    for joint in doc["joints"]:
        oracle = urdf.joint_map[joint["name"]]
        assert joint["type"] == oracle.type
        assert (joint["parent"], joint["child"]) == (oracle.parent, oracle.child)
        child = urdf.get_transform(frame_to=oracle.child, frame_from=urdf.base_link)
        if oracle.type in ("revolute", "continuous", "prismatic"):
            axis = child[:3, :3] @ (oracle.axis / np.linalg.norm(oracle.axis))
            assert np.allclose(joint["axis"], axis, atol=1e-12), joint["name"]
        else:
            assert joint["axis"] == [0.0, 0.0, 0.0]
        if oracle.limit is not None:
            assert joint["limits"]["velocity"] == oracle.limit.velocity
            assert joint["limits"]["effort"] == oracle.limit.effort
            assert joint["limits"]["lower"] == oracle.limit.lower
            assert joint["limits"]["upper"] == oracle.limit.upper


def test_demo_limits_in_json(capsys):
    doc = json.loads(_inspect(capsys, "demo", "--json"))
    joints = {j["name"]: j for j in doc["joints"]}
    assert [joints[f"joint{i}"]["limits"]["velocity"] for i in range(1, 8)] == [
        2.175,
        2.175,
        2.175,
        2.175,
        2.61,
        2.61,
        2.61,
    ]
    assert [joints[f"joint{i}"]["limits"]["effort"] for i in range(1, 8)] == [
        87,
        87,
        87,
        87,
        12,
        12,
        12,
    ]
    assert joints["joint4"]["limits"]["upper"] == -0.0698
    assert joints["finger_joint1"]["limits"]["upper"] == 0.04
    assert joints["finger_joint2"]["type"] == "prismatic"
    assert joints["j" + "oint1"]["pose"][:3] == [0.0, 0.0, 0.333]
    assert doc["frames"] == []


def test_human_table(capsys, data_dir):
    out = _inspect(capsys, str(data_dir / "rotated_chain.urdf"))
    assert out.startswith("model rotated_chain (urdf, ")
    assert "j2" in out
    assert "continuous" in out
    assert "a -> b" in out
    assert "tool" in out
