"""Fixtures of the model tests: real robot files from example-robot-data, a mesh cache."""

from __future__ import annotations

import sysconfig
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data" / "models"


def robots_dir() -> Path:
    """Where the PyPI package example-robot-data installs its robots."""
    for key in ("purelib", "platlib"):
        candidate = (
            Path(sysconfig.get_paths()[key]) / "cmeel.prefix/share/example-robot-data/robots"
        )
        if candidate.is_dir():
            return candidate
    raise RuntimeError("example-robot-data is not installed (a test dependency)")


@pytest.fixture(scope="session")
def robots() -> Path:
    return robots_dir()


@pytest.fixture(scope="session")
def mesh_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("meshes")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    return DATA
