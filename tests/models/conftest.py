"""Fixtures of the model tests: real robot files from example-robot-data, a mesh cache."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.models.paths import robots_dir

DATA = Path(__file__).resolve().parents[1] / "data" / "models"


@pytest.fixture(scope="session")
def robots() -> Path:
    return robots_dir()


@pytest.fixture(scope="session")
def mesh_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("meshes")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    return DATA
