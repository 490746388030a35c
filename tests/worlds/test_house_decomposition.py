"""turtlebot3_house's decomposition is vendored (``tests/data/worlds/turtlebot3/decomposition``,
issue 33): the house tests load it decomposed without two minutes of CoACD. These checks are
fast: the vendored entries are the names the current code, parameters and CoACD version look
up for the house's meshes (else a version bump would make the house tests silently slow),
and a load seeded with them never decomposes."""

from __future__ import annotations

import shutil
import warnings
from importlib.metadata import version
from pathlib import Path

import pytest

from harness.models import RobotSpec, load_world
from harness.models.build import decompose as decompose_module
from harness.models.sdf import worldfile
from tests.worlds.realworld import HOUSE_DECOMPOSITION, TB3, TB3_MODELS

HOUSE = TB3 / "worlds" / "turtlebot3_house.world"
BURGER = TB3_MODELS / "turtlebot3_burger" / "model.sdf"


@pytest.fixture
def house_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(TB3_MODELS))


def stale_entries(folder: Path, cache: Path) -> str:
    """ "" when the vendored entries in ``folder`` are exactly the names the current code looks
    up for the house's colliding meshes, else one line saying what differs and what to do."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the textures left out of tests/data
        world = worldfile.load_world_file(HOUSE, cache_dir=cache)
    expected = decompose_module.entry_names(world.spec, str(HOUSE))
    vendored = {p.name for p in folder.glob("decompose-*.npz")}
    stale = sorted(vendored - set(expected.values()))
    missing = sorted(mesh for mesh, name in expected.items() if name not in vendored)
    if not stale and not missing:
        return ""
    return (
        f"{folder}: vendored entries {stale} are not the keys this code and CoACD "
        f"{version('coacd')} compute; meshes {missing} would be decomposed cold (about two "
        "minutes per house test): regenerate the entries as the folder's README.md says"
    )


def test_the_vendored_entries_are_the_keys_the_current_code_computes(
    house_path: None, tmp_path: Path
) -> None:
    message = stale_entries(HOUSE_DECOMPOSITION, tmp_path)
    assert message == "", message


def test_a_changed_key_is_noticed_with_a_clear_message(house_path: None, tmp_path: Path) -> None:
    """The check itself: an entry under another name (another CoACD version) is reported."""
    folder = tmp_path / "vendored"
    shutil.copytree(HOUSE_DECOMPOSITION, folder)
    entry = sorted(folder.glob("decompose-*.npz"))[0]
    entry.rename(folder / "decompose-000000000000000000000000.npz")
    message = stale_entries(folder, tmp_path / "cache")
    assert "vendored entries ['decompose-000000000000000000000000.npz'] are not the keys" in message
    assert "regenerate the entries as the folder's README.md says" in message


def test_a_load_seeded_with_the_entries_never_decomposes(
    house_path: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    cache = tmp_path / "cache"
    shutil.copytree(HOUSE_DECOMPOSITION, cache)

    def refuse(*args: object, **kwargs: object) -> object:
        raise AssertionError("decomposed although the vendored entries were seeded")

    monkeypatch.setattr(decompose_module, "_load", refuse)  # no mesh read to be measured
    monkeypatch.setattr(decompose_module, "in_processes", refuse)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = load_world(
            [RobotSpec(str(BURGER), pose=(-2.0, -0.5, 0.01))], scene=str(HOUSE), cache_dir=cache
        )
    assert not [w for w in caught if "decomposing" in str(w.message)]
    pieces = [g for g in range(world.model.ngeom) if "#" in world.model.geom(g).name]
    assert len(pieces) > 10  # mailbox, two trash cans, the marble table
    attached = {n.removeprefix("decomposition/") for n in world.sources if "decompos" in n}
    assert attached == {p.name for p in HOUSE_DECOMPOSITION.glob("decompose-*.npz")}
