"""COLLADA node transforms (``<matrix>``, ``<translate>``, ``<rotate>``, ``<scale>``, nested)
are applied when a mesh is converted, as gz applies them: the converted triangles equal those
pycollada places in its scene (an independent reader) on Gazebo's own model meshes and on
nested transforms (issue 33). trimesh, which converts, composed them right before this issue:
these tests guard it."""

from __future__ import annotations

from pathlib import Path

import collada as pycollada
import numpy as np
import pytest
import trimesh

from harness.models.files.meshes import prepare_mesh
from tests.cameras.collada import collada

DATA = Path(__file__).resolve().parents[1] / "data"
REAL = [
    DATA / "gazebo_models/pioneer3at/meshes/chassis.dae",  # 16 nodes with <matrix>
    DATA / "gazebo_models/pioneer3at/meshes/wheel.dae",
    DATA / "descriptions/moveit_resources_panda_description/meshes/visual/link1.dae",
]


def _reference(path: Path) -> np.ndarray:
    """Every triangle (n x 3 x 3) as pycollada places it in the document's scene."""
    document = pycollada.Collada(str(path))
    triangles = []
    for geometry in document.scene.objects("geometry"):
        for primitive in geometry.primitives():
            tris = primitive.triangleset() if hasattr(primitive, "triangleset") else primitive
            triangles.append(np.asarray(tris.vertex)[np.asarray(tris.vertex_index)])
    return np.concatenate(triangles).reshape(-1, 3, 3)


def _converted(path: Path, cache: Path) -> np.ndarray:
    mesh = trimesh.load(str(prepare_mesh(path, cache_dir=cache)), force="mesh", process=False)
    return np.asarray(mesh.vertices)[np.asarray(mesh.faces)]


def _canonical(triangles: np.ndarray) -> np.ndarray:
    """The triangles as a set: each one's vertices in order, then the triangles in order
    (ordered by values rounded to 0.1 mm, so float32 rounding does not reorder them)."""
    out = np.empty_like(triangles)
    for i, triangle in enumerate(triangles):
        key = np.round(triangle, 4)
        out[i] = triangle[np.lexsort(key.T[::-1])]
    flat = out.reshape(len(out), 9)
    return flat[np.lexsort(np.round(flat, 4).T[::-1])]


def _same_triangles(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    np.testing.assert_allclose(_canonical(a), _canonical(b), atol=2e-5)


@pytest.mark.parametrize("path", REAL, ids=lambda p: p.name)
def test_gazebo_model_meshes_convert_with_their_node_transforms(path: Path, tmp_path: Path) -> None:
    _same_triangles(_converted(path, tmp_path), _reference(path))


@pytest.mark.parametrize(
    ("outer", "inner"),
    [
        ("<translate>1 2 3</translate><rotate>0 0 1 90</rotate>", "<scale>2 1 0.5</scale>"),
        ("<matrix>0 -1 0 0.5  1 0 0 0  0 0 1 -1  0 0 0 1</matrix>", "<rotate>1 0 0 30</rotate>"),
    ],
    ids=["translate-rotate-scale", "matrix-rotate"],
)
def test_nested_node_transforms_are_composed(outer: str, inner: str, tmp_path: Path) -> None:
    path = collada(tmp_path / "quad.dae", outer=outer, inner=inner)
    converted = _converted(path, tmp_path / "cache")
    _same_triangles(converted, _reference(path))
    assert not np.allclose(converted[:, :, 0], 0.0)  # moved off the x = 0 plane it is written in
