"""Optional: compare with libsdformat itself (Debian's libsdformat-dev 12.3, SDF <= 1.9).

The C++ program in oracle/ is compiled with g++ into a temporary folder; the test is skipped,
with the reason, when g++ or the sdformat12 pkg-config package is absent.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from harness.models.description import Pose
from harness.models.sdf import load_document
from harness.models.sdf.document import Entity

HERE = Path(__file__).parent
DATA = HERE.parent / "data" / "sdf"
ORACLE_VERSIONS = {f"1.{minor}" for minor in range(4, 10)}


@pytest.fixture(scope="module")
def oracle(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("g++") is None:
        pytest.skip("g++ is not installed")
    if shutil.which("pkg-config") is None:
        pytest.skip("pkg-config is not installed")
    flags = subprocess.run(
        ["pkg-config", "--cflags", "--libs", "sdformat12"], capture_output=True, text=True
    )
    if flags.returncode != 0:
        pytest.skip("libsdformat 12 is not installed (apt-get install libsdformat-dev)")
    binary = tmp_path_factory.mktemp("oracle") / "sdf_oracle"
    source = HERE / "oracle" / "sdf_oracle.cc"
    subprocess.run(
        ["g++", "-std=c++17", "-O1", str(source), "-o", str(binary), *flags.stdout.split()],
        check=True,
        capture_output=True,
    )
    return binary


def _files() -> list[Path]:
    return [
        p
        for p in sorted(DATA.glob("*.sdf")) + sorted((DATA / "harness").glob("*.sdf"))
        if load_document(p).version in ORACLE_VERSIONS
    ]


def _pose(values: list[float]) -> Pose:
    return Pose((values[0], values[1], values[2]), (values[3], values[4], values[5], values[6]))


def _close(a: Pose, b: Pose) -> bool:
    return a.is_close(b.normalized(), atol=1e-6)


@pytest.mark.parametrize("path", _files(), ids=lambda p: p.name)
def test_matches_libsdformat(oracle: Path, path: Path) -> None:
    env = dict(os.environ, SDF_PATH=str(path.parent))
    result = subprocess.run(
        [str(oracle), str(path)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        cwd=path.parent,
    )
    dump: dict[str, Any] = json.loads(result.stdout)
    doc = load_document(path)
    compared = 0
    for model_dump in dump["models"]:
        model: Entity = doc.root
        for part in model_dump["path"].split("::") if model_dump["path"] else []:
            model = model.child("model", part)
        if model.scope is not None:
            assert _close(
                doc.pose_in_model(model, model.scope), _pose(model_dump["pose_in_parent"])
            )
        for kind in ("links", "frames"):
            for name, values in model_dump[kind].items():
                got = doc.pose_in_model(model.child(kind[:-1], name), model)
                assert _close(got, _pose(values)), (model_dump["path"], name)
                compared += 1
        for name, values in model_dump["joints"].items():
            joint = model.child("joint", name)
            assert _close(doc.pose_in_model(joint, model), _pose(values["pose"])), name
            if "axis" in values:
                axis = doc.pose_in_root(model).inverse().rotate(doc.axis_in_root(joint))
                assert np.allclose(axis, values["axis"], atol=1e-6), name
            compared += 1
    assert compared > 0
