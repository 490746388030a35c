"""Names split in issue 32 (one word, one concept): the old spellings still read for one
release, each with one warning that names the new spelling."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import yaml

from harness.scenario import Scenario


def _scenario(
    tmp_path: Path, robot: dict[str, object], loggers: list[object] | None = None
) -> Path:
    doc: dict[str, object] = {"robots": [{"robot": "demo", **robot}]}
    if loggers is not None:
        doc["robots"][0]["loggers"] = loggers  # type: ignore[index]
    path = tmp_path / "scenario.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_robots_control_modes_are_spelled_modes(tmp_path: Path) -> None:
    path = _scenario(tmp_path, {"modes": [{"mode": "velocity", "joints": ["joint1"]}]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scenario = Scenario.load(path)
    (entry,) = scenario.robots[0].modes
    assert (entry.mode, entry.joints) == ("velocity", ("joint1",))


def test_the_old_controllers_spelling_of_modes_reads_with_one_warning(tmp_path: Path) -> None:
    path = _scenario(tmp_path, {"controllers": [{"type": "JointController", "mode": "kinematic"}]})
    with pytest.warns(FutureWarning, match=r"robots\[0\]\.controllers: .*spelled 'modes:'") as got:
        scenario = Scenario.load(path)
    assert len(got) == 1
    assert scenario.robots[0].modes[0].mode == "kinematic"


def test_modes_and_its_old_spelling_together_are_refused(tmp_path: Path) -> None:
    from harness.scenario import ScenarioError

    both = {"modes": [{"mode": "velocity"}], "controllers": [{"mode": "kinematic"}]}
    with pytest.raises(ScenarioError, match=r"robots\[0\]"):
        Scenario.load(_scenario(tmp_path, both))


def test_the_collision_loggers_flag_is_self_contacts(tmp_path: Path) -> None:
    new = _scenario(tmp_path, {}, [{"type": "CollisionLogger", "self_contacts": False}])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (spec,) = Scenario.load(new).robots[0].loggers
    assert spec.self_contacts is False  # type: ignore[union-attr]
    old = _scenario(tmp_path, {}, [{"type": "CollisionLogger", "self_collision": False}])
    with pytest.warns(FutureWarning, match="spelled 'self_contacts'"):
        (spec,) = Scenario.load(old).robots[0].loggers
    assert spec.self_contacts is False  # type: ignore[union-attr]


def test_a_moved_module_imports_from_its_old_path_as_the_same_module() -> None:
    code = (
        "import warnings, importlib\n"
        "warnings.simplefilter('error')\n"
        "import harness.models.build.compiler as new\n"
        "try:\n"
        "    importlib.import_module('harness.models.compiler')\n"
        "except DeprecationWarning as w:\n"
        "    print('warned:', w)\n"
        "warnings.simplefilter('ignore')\n"
        "old = importlib.import_module('harness.models.compiler')\n"
        "print('same:', old is new)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert "warned: harness.models.compiler moved to harness.models.build.compiler" in out
    assert "same: True" in out


def test_every_moved_path_resolves() -> None:
    from harness._moved import moved_modules

    moved = moved_modules()
    assert len(moved) >= 30
    for new in moved.values():
        importlib.import_module(new)
