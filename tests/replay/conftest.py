"""Fixtures of the replay tests: real recordings of the demo robot, made once per worker."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

HERE = Path(__file__).resolve().parent


def _load(name: str) -> ModuleType:
    module_name = f"replay_tests_{name}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, HERE / f"{name}.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def helper() -> ModuleType:
    """tests/replay/record_helper.py."""
    return _load("record_helper")


@pytest.fixture(scope="session")
def mcap_edit() -> ModuleType:
    """tests/replay/mcap_edit.py."""
    return _load("mcap_edit")


@pytest.fixture(scope="session")
def base_recording(helper: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """300 steps of the demo arm in position mode, two commands, exact model attached."""
    path = tmp_path_factory.mktemp("base") / "base.mcap"
    return helper.record(path, {0: helper.REACH, 150: helper.BACK}, 300)  # type: ignore[no-any-return]
