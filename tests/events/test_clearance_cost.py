"""The clearance logger's cheaper set-up and broad phase give the exhaustive minimum: every
pair measured at every observed step with ``mj_geomDistance(..., distmax)``, the first step
the minimum is reached at, ties to the first pair (robot geom id, then world geom id), on both
forms of the broad phase (one matrix, per pair); the resting pairs found at the first step
without measuring the pairs whose bound says they are apart."""

from __future__ import annotations

import fnmatch

import mujoco
import numpy as np
import pytest

import harness.events.clearance as clearance_module
from harness.events import Clearance, ClearanceLogger, StepContext

# an arm (two links) swinging over a rotated fixed box, a plane, a fixed sphere; a free ball
# falling onto the table, a mocap block moved by the test; unnamed geoms; the arm's base
# rests on the floor (left out)
SCENE = """
<mujoco><option timestep="0.002"/><worldbody>
<geom name="floor" type="plane" size="5 5 0.1"/>
<geom name="table" type="box" size="0.4 0.3 0.02" pos="0 0 0.4" euler="0 0 30"/>
<geom type="sphere" size="0.03" pos="0.35 0.1 0.55"/>
<geom name="rail" type="capsule" fromto="-0.4 0.3 0.5 0.4 0.3 0.5" size="0.01"/>
<body name="base" pos="0 0 0.05"><geom name="foot" type="box" size="0.05 0.05 0.05"/>
<body name="link1" pos="0 0 0.4"><joint name="j1" type="hinge" axis="0 0 1" damping="0.1"/>
  <geom name="upper" type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.02"/>
  <body name="link2" pos="0.2 0 0.1"><joint name="j2" type="hinge" axis="0 1 0" damping="0.1"/>
    <geom type="box" size="0.1 0.015 0.015" pos="0.1 0 0"/>
    <geom name="tip" type="cylinder" size="0.02 0.02" pos="0.2 0 0"/></body></body></body>
<body name="ball" pos="-0.2 -0.2 0.7"><freejoint/>
  <geom name="ball" type="sphere" size="0.04"/></body>
<body name="block" mocap="true" pos="0.3 -0.3 0.6">
  <geom name="block" type="box" size="0.03 0.03 0.03"/></body>
</worldbody><actuator><motor joint="j1" gear="1"/><motor joint="j2" gear="1"/></actuator></mujoco>
"""
ROBOT = ["base", "link1", "link2"]
IGNORE = [("rail", "tip*"), ("link1", "ball")]


def exhaustive(
    model: mujoco.MjModel, steps: list[tuple[int, mujoco.MjData]], pairs: list[tuple[int, int]]
) -> tuple[float, int, tuple[int, int] | None]:
    """The documented minimum, measured plainly: every pair at every step."""
    best: tuple[float, int, tuple[int, int] | None] = (1.0, -1, None)
    for step, data in steps:
        for a, b in pairs:  # in pair order: the first of equal distances stays
            d = mujoco.mj_geomDistance(model, data, a, b, 1.0, None)
            if d < best[0]:
                best = (d, step, (a, b))
    return best


def reference_pairs(model: mujoco.MjModel, robot: set[int]) -> list[tuple[int, int]]:
    """The pairs as the logger documents them, name by name."""

    def names(g: int) -> tuple[str, str]:
        b = int(model.geom_bodyid[g])
        return (model.body(b).name or f"body{b}", model.geom(g).name or f"geom{g}")

    def match(n: tuple[str, str], p: str) -> bool:
        return any(fnmatch.fnmatchcase(x, p) for x in n)

    out = []
    for a in range(model.ngeom):
        for b in range(model.ngeom):
            if int(model.geom_bodyid[a]) not in robot or int(model.geom_bodyid[b]) in robot:
                continue
            ca, cb = model.geom_contype, model.geom_conaffinity
            if not ((ca[a] & cb[b]) or (ca[b] & cb[a])):
                continue
            na, nb = names(a), names(b)
            if any(
                (match(na, p) and match(nb, q)) or (match(na, q) and match(nb, p))
                for p, q in IGNORE
            ):
                continue
            out.append((a, b))
    return out


@pytest.mark.parametrize("few", [4, 0, 1000], ids=["as built", "by bound", "by pair"])
@pytest.mark.parametrize("dense_limit", [1 << 16, 0], ids=["one matrix", "per pair"])
def test_clearance_is_the_exhaustive_minimum(
    dense_limit: int, few: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Both forms of the broad phase; candidates measured nearest bound first or in pair
    order (how many candidates choose)."""
    monkeypatch.setattr(clearance_module, "_DENSE_LIMIT", dense_limit)
    monkeypatch.setattr(clearance_module, "_FEW", few)
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    logger = ClearanceLogger(model, robot_bodies=ROBOT, ignore=IGNORE, distmax=1.0)
    robot = {model.body(n).id for n in ROBOT}
    assert logger._pairs.tolist() == [list(p) for p in reference_pairs(model, robot)]
    rng = np.random.default_rng(7)
    steps: list[tuple[int, mujoco.MjData]] = []
    for k in range(1, 301):
        data.ctrl[:] = rng.uniform(-0.6, 0.6, 2)
        data.mocap_pos[0] = (0.3 * np.cos(k / 40), -0.3, 0.5 + 0.1 * np.sin(k / 30))
        mujoco.mj_step(model, data)
        logger.observe(StepContext(k, k * 2_000_000, model, data, None, "arm"))  # type: ignore[arg-type]
        if k == 1:  # the base's foot rests on the floor: left out from the first step on
            foot, floor = model.geom("foot").id, model.geom("floor").id
            assert [foot, floor] not in logger._pairs.tolist()
            assert [foot, model.geom("table").id] in logger._pairs.tolist()
        steps.append((k, mujoco.MjData(model)))
        mujoco.mj_copyData(steps[-1][1], model, data)
        bound = logger._bounds.lower(data.geom_xpos)
        for (a, b), low in zip(logger._pairs.tolist(), bound.tolist(), strict=True):
            if low > 0.0:
                assert low <= mujoco.mj_geomDistance(model, data, a, b, 10.0, None) + 1e-12
    pairs = [(int(a), int(b)) for a, b in logger._pairs]
    distance, step, pair = exhaustive(model, steps, pairs)
    assert pair is not None
    assert logger.minimum.distance < 0.05  # the arm came close
    assert (logger.minimum.distance, logger.minimum.step) == (distance, step)
    body = model.geom_bodyid
    assert logger.minimum == Clearance(
        distance,
        step,
        logger._bodies[body[pair[0]]],
        logger._bodies[body[pair[1]]],
        logger._geoms[pair[0]],
        logger._geoms[pair[1]],
    )


TIE = """
<mujoco><worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
<body name="robot" pos="0 0 1">
  <geom name="ball" type="sphere" size="0.25" pos="-1 0 0"/>
  <geom name="cube" type="box" size="0.25 0.25 0.25" pos="1 0 0"/></body>
</worldbody></mujoco>
"""


@pytest.mark.parametrize("few", [4, 0], ids=["by pair", "by bound"])
def test_clearance_ties_go_to_the_first_pair(few: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The ball and the cube are both 0.75 m above the floor; the cube's bounding sphere is
    the larger, so its bound is the lower; the minimum still names the first pair (the ball),
    as measuring every pair does, not the pair the broad phase happened to meet first."""
    monkeypatch.setattr(clearance_module, "_FEW", few)
    model = mujoco.MjModel.from_xml_string(TIE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    logger = ClearanceLogger(model, robot_bodies=["robot"])
    logger.observe(StepContext(1, 2_000_000, model, data, None, "robot"))  # type: ignore[arg-type]
    assert logger.minimum == Clearance(0.75, 1, "robot", "world", "ball", "floor")


def test_clearance_start_measures_only_pairs_that_may_rest(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """At the first observed step only the pairs whose bound is within a millimetre are
    measured to find the resting ones (there: the foot on the floor)."""
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    logger = ClearanceLogger(model, robot_bodies=ROBOT, ignore=IGNORE)
    pairs = logger._pairs.tolist()
    measured: list[tuple[int, int, float]] = []
    real = mujoco.mj_geomDistance

    def counted(m, d, a, b, distmax, fromto):  # type: ignore[no-untyped-def]
        measured.append((a, b, distmax))
        return real(m, d, a, b, distmax, fromto)

    monkeypatch.setattr(mujoco, "mj_geomDistance", counted)
    logger.observe(StepContext(0, 0, model, data, None, "arm"))  # type: ignore[arg-type]
    at_start = [(a, b) for a, b, distmax in measured if distmax < 1e-3]
    foot, floor = model.geom("foot").id, model.geom("floor").id
    assert (foot, floor) in at_start
    assert len(at_start) <= len(pairs) // 4
    assert [foot, floor] not in logger._pairs.tolist()
    assert len(logger._pairs) == len(pairs) - 1


def test_pairs_are_made_once_per_names_and_masks() -> None:
    """A warm world's next model (other object values, the same names, bodies and collision
    masks) gets the pairs made for the first; a model whose masks differ gets its own."""
    first = mujoco.MjModel.from_xml_string(SCENE)
    moved = mujoco.MjModel.from_xml_string(SCENE.replace('pos="0.35 0.1 0.55"', 'pos="0.3 0 0.6"'))
    masked = mujoco.MjModel.from_xml_string(
        SCENE.replace(
            'name="rail" type="capsule"', 'name="rail" contype="0" conaffinity="0" type="capsule"'
        )
    )
    one = ClearanceLogger(first, robot_bodies=ROBOT, ignore=IGNORE)
    two = ClearanceLogger(moved, robot_bodies=ROBOT, ignore=IGNORE)
    assert two._pairs is one._pairs
    other = ClearanceLogger(masked, robot_bodies=ROBOT, ignore=IGNORE)
    rail = masked.geom("rail").id
    assert rail in one._pairs[:, 1].tolist()
    assert rail not in other._pairs[:, 1].tolist()
    assert ClearanceLogger(first, robot_bodies=ROBOT)._pairs is not one._pairs  # no ignore
