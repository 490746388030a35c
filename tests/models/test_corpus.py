"""Every URDF of example-robot-data either compiles or fails with a HarnessError naming why.

The expected failures are listed with their cause, so a regression (a file that stops
compiling, or a new kind of error) fails the test. Loaded with the defaults (lenient: bad
inertias repaired, thin meshes given shell inertia, unknown mimics dropped, each with a
warning): 68 of 69 compile; with ``strict=True`` 43 do (inertia problems).
"""

from __future__ import annotations

import warnings

import pytest

from harness.errors import HarnessError
from harness.models import load_robot
from harness.models.errors import ModelWarning

from .conftest import robots_dir

URDFS = sorted(robots_dir().rglob("*.urdf"))

EXPECTED_FAILURES = {
    # an empty xacro stub: nothing to load
    "ur_description/urdf/ur3.urdf": "<robot> has no <link>",
}


def test_corpus_is_complete():
    assert len(URDFS) == 69
    missing = set(EXPECTED_FAILURES) - {str(p.relative_to(robots_dir())) for p in URDFS}
    assert not missing


@pytest.mark.parametrize("path", URDFS, ids=lambda p: str(p.relative_to(robots_dir())))
def test_each_urdf_compiles_or_names_the_cause(path, mesh_cache):
    relative = str(path.relative_to(robots_dir()))
    expected = EXPECTED_FAILURES.get(relative)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ModelWarning)
            loaded = load_robot(path, cache_dir=mesh_cache)
    except HarnessError as exc:
        message = str(exc)
        assert str(path) in message
        assert "\n" not in message
        assert expected is not None, f"unexpected failure: {message}"
        assert expected in message
        return
    assert expected is None, f"expected to fail with {expected!r} but compiled"
    bodies = {loaded.model.body(b).name for b in range(loaded.model.nbody)}
    assert {link.name for link in loaded.description.links} <= bodies | {"world"}
    assert loaded.model.nu == len(loaded.actuated)
