"""Every expected value transcribed from libsdformat's integration tests (tests/data/sdf)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from harness.models.description import Pose
from harness.models.sdf import SdfDocument, load_document
from harness.models.sdf.document import Entity

DATA = Path(__file__).parent.parent / "data" / "sdf"
EXPECTED = json.loads((DATA / "expected.json").read_text())
TOL = 1e-6


def _cases() -> list[Any]:
    cases = []
    for file, info in EXPECTED["files"].items():
        for index, assertion in enumerate(info["assertions"]):
            rel = assertion.get("relative_to")
            label = f"{file}#{index}:{assertion['kind']}:{assertion['entity']}"
            if rel is not None:
                label += f"@{rel}"
            cases.append(pytest.param(file, assertion, id=label))
    return cases


_DOCS: dict[str, SdfDocument] = {}


def _doc(file: str) -> SdfDocument:
    if file not in _DOCS:
        _DOCS[file] = load_document(DATA / file)
    return _DOCS[file]


def _entity(doc: SdfDocument, path: str) -> Entity:
    entity = doc.root
    if path == ".":
        return entity
    for part in path.split("/"):
        kind, _, name = part.partition("=")
        entity = entity.child(kind, name)
    return entity


def _expected_pose(expected: dict[str, Any]) -> Pose:
    if "pose_xyzrpy" in expected:
        v = expected["pose_xyzrpy"]
        return Pose.from_xyz_rpy(v[:3], v[3:])
    v = expected["pose_xyz_quat_wxyz"]
    return Pose((v[0], v[1], v[2]), (v[3], v[4], v[5], v[6])).normalized()


def _assert_pose(actual: Pose, expected: Pose, rotation_only: bool = False) -> None:
    dot = abs(sum(a * b for a, b in zip(actual.quat, expected.quat, strict=True)))
    assert 1.0 - min(1.0, dot) <= TOL, f"rotation {actual.quat} != {expected.quat}"
    if not rotation_only:
        assert actual.xyz == pytest.approx(expected.xyz, abs=TOL), "translation"


def test_corpus_has_152_assertions() -> None:
    assert len(_cases()) == 152


@pytest.mark.parametrize(("file", "assertion"), _cases())
def test_expected(file: str, assertion: dict[str, Any]) -> None:
    doc = _doc(file)
    kind = assertion["kind"]
    entity = _entity(doc, assertion["entity"])
    expected = assertion["expected"]
    if kind == "pose":
        actual = doc.pose(entity, assertion["relative_to"])
        if assertion.get("compare") == "rotation_only":
            rpy = expected["rot_rpy"]
            _assert_pose(actual, Pose.from_xyz_rpy((0, 0, 0), rpy), rotation_only=True)
        else:
            _assert_pose(actual, _expected_pose(expected))
    elif kind == "raw_pose":
        _assert_pose(entity.raw_pose.pose, _expected_pose(expected))
    elif kind == "inertial_pose":
        assert entity.inertial is not None
        _assert_pose(entity.inertial.raw_pose.pose, _expected_pose(expected))
    elif kind == "axis_xyz":
        vector = doc.axis(entity, assertion["axis_index"], assertion["relative_to"])
        assert vector == pytest.approx(expected["vector"], abs=TOL)
    elif kind == "axis_raw":
        assert entity.joint is not None
        axis = entity.joint.axes[assertion["axis_index"]]
        assert axis.xyz == pytest.approx(expected["xyz"], abs=TOL)
        assert axis.expressed_in == expected["expressed_in"]
        for key in (
            "lower",
            "upper",
            "effort",
            "max_velocity",
            "damping",
            "friction",
            "spring_reference",
            "spring_stiffness",
        ):
            if key in expected:
                assert getattr(axis, key) == pytest.approx(expected[key], abs=TOL), key
    elif kind == "attached_to":
        assert entity.attached_to == expected["attached_to"]
    elif kind == "attached_to_body":
        assert entity.scope is not None
        assert doc.relative_name(doc.body(entity), entity.scope) == expected["body"]
    elif kind == "joint_links":
        assert entity.joint is not None
        assert entity.scope is not None
        assert entity.joint.parent == expected["parent"]
        assert entity.joint.child == expected["child"]
        parent, child = doc.joint_links(entity)
        assert doc.relative_name(parent, entity.scope) == expected["resolved_parent_link"]
        assert doc.relative_name(child, entity.scope) == expected["resolved_child_link"]
    elif kind == "joint_types_in_order":
        types = [j.joint.type for j in entity.of_kind("joint") if j.joint is not None]
        assert types == expected
    elif kind == "original_version":
        assert doc.version == expected["original_version"]
    else:
        pytest.fail(f"unknown assertion kind {kind!r}")


def _walk_dump(file: str, scope: list[str], model: dict[str, Any], cases: list[Any]) -> None:
    path = [*scope, model["name"]]
    label = f"{file}:{'::'.join(path)}"
    cases.append(pytest.param(file, path, "model", "", model, id=f"{label}:pose_in_parent"))
    for kind in ("links", "joints", "frames"):
        for name, values in model[kind].items():
            cases.append(pytest.param(file, path, kind[:-1], name, values, id=f"{label}:{name}"))
    for nested in model["models"]:
        _walk_dump(file, path, nested, cases)


def _dump_cases() -> list[Any]:
    cases: list[Any] = []
    for file, info in EXPECTED["files"].items():
        dump = info["oracle_dump"]
        for model in dump["models"]:
            _walk_dump(file, [], model, cases)
        for world in dump["worlds"]:
            for name, values in world["frames"].items():
                cases.append(pytest.param(file, [], "frame", name, values, id=f"{file}:{name}"))
            for model in world["models"]:
                _walk_dump(file, [], model, cases)
    return cases


def _dump_pose(values: dict[str, Any]) -> Pose:
    return Pose(tuple(values["xyz"]), tuple(values["quat_wxyz"])).normalized()  # type: ignore[arg-type]


@pytest.mark.parametrize(("file", "path", "kind", "name", "values"), _dump_cases())
def test_oracle_dump(
    file: str, path: list[str], kind: str, name: str, values: dict[str, Any]
) -> None:
    """libsdformat 12.3's resolution of every entity (not asserted upstream; wider net)."""
    doc = _doc(file)
    model = doc.root
    for part in path if doc.root.kind == "world" else path[1:]:
        model = model.child("model", part)
    if kind == "model":
        parent = model.scope if model.scope is not None else model
        got = doc.pose_in_model(model, parent) if model.scope is not None else Pose()
        want = _dump_pose(values["pose_in_parent"]) if model.scope is not None else Pose()
        _assert_pose(got, want)
        if values.get("canonical_link"):
            assert doc.relative_name(doc.canonical_link(model), model) == values["canonical_link"]
        return
    entity = model.child(kind, name)
    in_key = "in_world" if model.kind == "world" else "in_model"
    _assert_pose(doc.pose_in_model(entity, model), _dump_pose(values[in_key]))
    if kind == "frame":
        assert entity.attached_to == values["attached_to"]
        assert doc.relative_name(doc.body(entity), model) == values["attached_to_body"]
    if kind == "joint":
        parent, child = doc.joint_links(entity)
        assert doc.relative_name(parent, model) == values["resolved_parent_link"]
        assert doc.relative_name(child, model) == values["resolved_child_link"]
        axis = values.get("axis")
        if axis is not None:
            in_model = doc.pose_in_root(model).inverse().rotate(doc.axis_in_root(entity, 0))
            assert in_model == pytest.approx(axis["xyz_in_model"], abs=TOL)
            assert doc.axis(entity, 0) == pytest.approx(axis["xyz_in_joint"], abs=TOL)


def test_oracle_dump_is_not_empty() -> None:
    assert len(_dump_cases()) > 100
