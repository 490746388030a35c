"""Fixtures of the recording tests: a realistic recording made once per worker."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

HERE = Path(__file__).resolve().parent
STEPS = 600


def _load_record_run() -> ModuleType:
    spec = importlib.util.spec_from_file_location("recording_record_run", HERE / "record_run.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def record_run() -> ModuleType:
    """tests/recording/record_run.py as a module."""
    return _load_record_run()


@pytest.fixture(scope="session")
def run_recording(record_run: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A closed recording of STEPS steps of the test arm with every kind of record."""
    path = tmp_path_factory.mktemp("run") / "run.mcap"
    record_run.record(path, STEPS)
    return path
