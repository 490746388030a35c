"""Decomposition that is fast where it can be (issue 33): a mesh whose own convex hull is within
the 2 cm bound never reaches CoACD and is cached as one hull; CoACD runs capped, and a bound it
does not reach is one warning naming the mesh and the distance; a moving robot's concave link
mesh is decomposed, attached to its recording, and replay never decomposes."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from harness.models.build import decompose as decompose_module
from harness.models.errors import ModelWarning

from .test_mesh_decomposition import _wall


def _dented_box() -> trimesh.Trimesh:
    """A closed 20 cm box whose top has a 15 mm dent: not convex (its volume is 0.3 % below
    its hull's), yet its hull is within 2 cm of its triangles."""
    box = trimesh.creation.box((0.2, 0.2, 0.2)).subdivide().subdivide()
    top = int(np.argmin(np.linalg.norm(box.vertices - [0.0, 0.0, 0.1], axis=1)))
    vertices = box.vertices.copy()
    vertices[top, 2] -= 0.015
    return trimesh.Trimesh(vertices, box.faces, process=False)


def _stl(mesh: trimesh.Trimesh) -> bytes:
    out = io.BytesIO()
    mesh.export(out, file_type="stl")
    return out.getvalue()


def _refuse(*args: object, **kwargs: object) -> object:
    raise AssertionError("CoACD ran")


def test_a_hull_within_the_bound_never_reaches_coacd(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    dented = _dented_box()
    assert dented.volume < 0.999 * dented.convex_hull.volume  # not taken as convex
    monkeypatch.setattr(decompose_module, "_run_coacd", _refuse)
    result = decompose_module.decompose_mesh(_stl(dented), ".stl", cache_dir=tmp_path)
    assert result.kind == "hull"
    assert result.pieces == ()
    assert 0.01 < result.deviation <= decompose_module.MAX_DEVIATION
    # cached like a decomposition, noted as a hull: read back, never measured again
    monkeypatch.setattr(decompose_module, "deviation", _refuse)
    again = decompose_module.decompose_mesh(_stl(dented), ".stl", cache_dir=tmp_path)
    assert (again.kind, again.deviation, again.cache_file) == (
        "hull",
        result.deviation,
        result.cache_file,
    )
    assert (tmp_path / result.cache_file).is_file()


def test_coacd_runs_capped_and_a_missed_bound_is_one_warning(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import coacd

    calls: list[dict[str, Any]] = []

    def hull_only(mesh: Any, **kwargs: Any) -> list[Any]:
        calls.append(kwargs)  # CoACD's answer: the whole hull, 2.5 m off the ring wall
        hull = trimesh.Trimesh(mesh.vertices, mesh.indices).convex_hull
        return [(hull.vertices, hull.faces)]

    monkeypatch.setattr(coacd, "run_coacd", hull_only)
    with pytest.warns(ModelWarning) as caught:
        result = decompose_module.decompose_mesh(
            _stl(_wall()), ".stl", cache_dir=tmp_path, where="arena: wall"
        )
    assert result.kind == "pieces"
    assert len(calls) == len(decompose_module.THRESHOLDS)
    for kwargs in calls:
        assert 0 < kwargs["max_convex_hull"] <= 64
        assert kwargs["preprocess_resolution"] < 50  # CoACD's defaults: 50, 150, 3
        assert kwargs["mcts_iterations"] < 150
        assert kwargs["mcts_max_depth"] < 3
    messages = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert len(messages) == 1
    assert messages[0].startswith("arena: wall: convex pieces stay ")
    assert f"{result.deviation * 1000:.0f} mm from the mesh (bound 20 mm)" in messages[0]


def _arm(folder: Path) -> Path:
    """A robot whose moving link's collision mesh is the concave ring wall."""
    _wall().export(folder / "wall.stl")
    path = folder / "arm.urdf"
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    path.write_text(
        f'<robot name="arm"><link name="base">{inertial}</link>'
        f'<link name="ring">{inertial}'
        '<collision><geometry><mesh filename="wall.stl"/></geometry></collision></link>'
        '<joint name="turn" type="revolute"><parent link="base"/><child link="ring"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        "</robot>"
    )
    return path


def test_an_entry_from_before_the_caps_is_still_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A recording made before CoACD was capped carries its entry under the earlier key
    (format 1, no CoACD options, no ``kind``): a rebuild reads it and never decomposes."""
    import hashlib
    import json
    from importlib.metadata import version

    data = _stl(_wall())
    params = {"max_deviation": 0.02, "thresholds": [0.05, 0.025, 0.0125], "samples": 4000}
    header = json.dumps(["harness-decompose-1", version("coacd"), params, [1.0] * 3, ".stl"])
    digest = hashlib.sha256(header.encode() + b"\0" + data).hexdigest()[:24]
    name = f"decompose-{digest}.npz"
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    np.savez(
        tmp_path / name,
        count=np.array(1),
        deviation=np.array(0.01),
        threshold=np.array(0.05),
        v0=np.asarray(box.vertices),
        f0=np.asarray(box.faces, np.int32),
    )
    monkeypatch.setattr(decompose_module, "_run_coacd", _refuse)
    result = decompose_module.decompose_mesh(data, ".stl", cache_dir=tmp_path)
    assert (result.kind, len(result.pieces), result.cache_file) == ("pieces", 1, name)
    assert np.array_equal(result.pieces[0][0], box.vertices)
