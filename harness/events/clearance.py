"""The clearance logger: how close a robot came to the world, as a margin to search on.

:class:`ClearanceLogger` measures, at each observed step, the smallest signed distance
(``mujoco.mj_geomDistance``) between any geom of the robot and any geom of the world it can
collide with (``contype``/``conaffinity``), and keeps the run's minimum with the step and the
body pair. It emits no events: adding it to a session changes nothing in the recording, so a
search (``harness explore``'s ``target: min_clearance``) can watch a margin shrink toward a
collision without changing what it records.

Pairs already touching at the first observed step (the arm's base on its table) are left out:
their clearance is zero by construction and says nothing. ``ignore``: name pattern pairs
(shell-style, either order, each pattern matching a body or a geom name: fixed scenario objects
and the floor are geoms of the ``world`` body), e.g. the scenario's ``allowed_collisions``.
A bounding-sphere bound prunes the pairs: only pairs that could beat the current minimum are
measured exactly.
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events.errors import LoggerConfigError
from harness.events.events import Event
from harness.events.logger import StepContext, period_ns_from_hz

__all__ = ["Clearance", "ClearanceLogger"]

_TOUCHING = 1e-6  # metres: a pair this close at the start is resting, not a margin


class Clearance(NamedTuple):
    """The smallest clearance seen: ``distance`` in metres (negative: penetration), the step,
    and the robot's and the world's body and geom of the pair (``distance`` is ``distmax`` and
    the names empty when nothing came within ``distmax``). A fixed scenario object is a geom
    of the ``world`` body: its geom names it."""

    distance: float
    step: int
    robot_body: str
    other_body: str
    robot_geom: str = ""
    other_geom: str = ""


class ClearanceLogger:
    """Minimum robot-to-world clearance over a run (see the module docstring).

    ``robot_bodies``: the robot's body names; ``ignore``: body or geom name pattern pairs
    left out;
    ``distmax`` (m): distances beyond it are not resolved (reported as ``distmax``);
    ``rate_hz``: observations per simulation second (None: every step).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        robot_bodies: Iterable[str],
        ignore: Iterable[tuple[str, str]] = (),
        distmax: float = 1.0,
        rate_hz: float | None = None,
        name: str = "clearance",
    ) -> None:
        if not (math.isfinite(distmax) and distmax > 0):
            raise LoggerConfigError(f"clearance logger {name!r}: distmax must be > 0 m")
        self._name = name
        try:
            self._period = period_ns_from_hz(rate_hz)
        except ValueError as exc:
            raise LoggerConfigError(f"clearance logger {name!r}: {exc}") from None
        self.distmax = float(distmax)
        bodies = [model.body(i).name or f"body{i}" for i in range(model.nbody)]
        index = {n: i for i, n in enumerate(bodies)}
        robot: set[int] = set()
        for i, body in enumerate(robot_bodies):
            if body not in index:
                raise LoggerConfigError(
                    f"clearance logger {name!r}: robot_bodies[{i}]: no body named {body!r}"
                )
            robot.add(index[body])
        robot.discard(0)
        if not robot:
            raise LoggerConfigError(f"clearance logger {name!r}: needs at least one robot body")
        patterns = list(ignore)
        self._bodies = bodies
        self._geoms = geoms = [model.geom(i).name or f"geom{i}" for i in range(model.ngeom)]
        body_of = model.geom_bodyid
        contype, conaffinity = model.geom_contype, model.geom_conaffinity
        mine = [g for g in range(model.ngeom) if int(body_of[g]) in robot]
        theirs = [g for g in range(model.ngeom) if int(body_of[g]) not in robot]
        pairs = [
            (a, b)
            for a in mine
            for b in theirs
            if (contype[a] & conaffinity[b]) or (contype[b] & conaffinity[a])
            if not _ignored(
                (bodies[body_of[a]], geoms[a]), (bodies[body_of[b]], geoms[b]), patterns
            )
        ]
        self._pairs: npt.NDArray[np.intp] = np.array(pairs, dtype=np.intp).reshape(-1, 2)
        self._started = False
        self._bounds = _Bounds(None, None, self._pairs)
        self.minimum = Clearance(self.distmax, -1, "", "")
        """The smallest clearance so far (see :class:`Clearance`)."""

    @property
    def name(self) -> str:
        return self._name

    @property
    def period_ns(self) -> int:
        return self._period

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """Measure this step's clearance (no events)."""
        if not self._started:
            self._drop_resting(ctx)
            self._bounds = _Bounds(ctx.model, ctx.data, self._pairs)
        pairs = self._pairs
        if not len(pairs):
            return []
        bound = self._bounds.lower(ctx.data.geom_xpos)
        best = self.minimum.distance
        # a bound <= 0 may hide an overlap (not a lower bound then): measured below a best
        # <= 0; with best > 0 it is below best anyway
        near = np.flatnonzero((bound < best) | (bound <= 0.0) if best <= 0.0 else bound < best)
        if not near.size:
            return []
        if near.size > 1:
            near = near[np.argsort(bound[near], kind="stable")]
        model, data = ctx.model, ctx.data
        for i in near.tolist():
            if bound[i] >= best and bound[i] > 0.0:
                break
            ga, gb = int(pairs[i, 0]), int(pairs[i, 1])
            d = mujoco.mj_geomDistance(model, data, ga, gb, best, None)
            if d < best:
                best = d
                body = model.geom_bodyid
                self.minimum = Clearance(
                    float(d),
                    ctx.step,
                    self._bodies[body[ga]],
                    self._bodies[body[gb]],
                    self._geoms[ga],
                    self._geoms[gb],
                )
        return []

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        return []

    def _drop_resting(self, ctx: StepContext) -> None:
        self._started = True
        keep = [
            bool(
                mujoco.mj_geomDistance(ctx.model, ctx.data, int(a), int(b), _TOUCHING * 2, None)
                > _TOUCHING
            )
            for a, b in self._pairs
        ]
        self._pairs = self._pairs[np.array(keep, dtype=bool)] if keep else self._pairs


def _ignored(a: tuple[str, str], b: tuple[str, str], patterns: list[tuple[str, str]]) -> bool:
    """Whether a pair of (body, geom) names matches an ignore pattern pair, either order."""

    def match(names: tuple[str, str], pattern: str) -> bool:
        return any(fnmatch.fnmatchcase(n, pattern) for n in names)

    return any(
        (match(a, pa) and match(b, pb)) or (match(a, pb) and match(b, pa)) for pa, pb in patterns
    )


_PLANE_DEPTH = 1e4  # metres: a plane bounds the half-space below it, as a box this deep
_NO_BOUND = np.zeros(0)


class _Bounds:
    """Lower bounds of the pairs' distances from geom poses (the broad phase).

    A pair whose other geom is fixed in the world (welded to it, not mocap) is bounded by the
    distance from the robot geom's bounding sphere to the other geom's bounding box (MuJoCo's
    ``geom_aabb`` in the geom's frame; a plane: the half-space below it), read once; other
    pairs by their two bounding spheres (0 radius, a plane: unbounded: ``-inf``). A positive
    bound is a true lower bound of the distance; one <= 0 says the volumes may overlap (an
    overlap's depth is not bounded: such a pair is measured whatever the minimum).
    """

    def __init__(
        self,
        model: mujoco.MjModel | None,
        data: mujoco.MjData | None,
        pairs: npt.NDArray[np.intp],
    ) -> None:
        self._n = len(pairs)
        self._all_fixed = False
        if model is None or data is None or not self._n:
            self._fixed = self._moving = np.zeros(0, dtype=np.intp)
            return
        a, b = pairs[:, 0], pairs[:, 1]
        rbound = np.asarray(model.geom_rbound, dtype=np.float64)
        body = np.asarray(model.geom_bodyid)
        fixed = (np.asarray(model.body_weldid)[body[b]] == 0) & (
            np.asarray(model.body_mocapid)[body[b]] < 0
        )
        self._fixed = np.flatnonzero(fixed)
        self._moving = np.flatnonzero(~fixed)
        self._all_fixed = not self._moving.size
        f = self._fixed
        self._fa = a[f]
        self._fr = rbound[a[f]]
        gb = b[f]
        rot = np.asarray(data.geom_xmat)[gb].reshape(-1, 3, 3)
        aabb = np.asarray(model.geom_aabb)[gb].reshape(-1, 6)
        center, half = aabb[:, :3].copy(), aabb[:, 3:].copy()
        plane = np.asarray(model.geom_type)[gb] == mujoco.mjtGeom.mjGEOM_PLANE
        center[plane] = (0.0, 0.0, -_PLANE_DEPTH)
        half[plane] = (np.inf, np.inf, _PLANE_DEPTH)
        self._rot = rot
        self._center = np.asarray(data.geom_xpos)[gb] + np.einsum("kij,kj->ki", rot, center)
        self._half = half
        m = self._moving
        self._ma, self._mb = a[m], b[m]
        ra, rb = rbound[a[m]], rbound[b[m]]
        self._mr = ra + rb
        self._unbounded = (ra == 0) | (rb == 0)  # planes: unbounded, always measured
        self._any_unbounded = bool(self._unbounded.any())

    def lower(self, xpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Per pair: a lower bound of its distance now (``xpos``: ``data.geom_xpos``)."""
        bound = _NO_BOUND if self._all_fixed else np.empty(self._n)
        if self._fixed.size:
            d = xpos[self._fa] - self._center
            q = np.abs(np.einsum("ki,kij->kj", d, self._rot))  # |R^T d|, row by row
            q -= self._half
            np.maximum(q, 0.0, out=q)
            gap: npt.NDArray[np.float64] = np.sqrt(np.einsum("ki,ki->k", q, q)) - self._fr
            if self._all_fixed:
                return gap
            bound[self._fixed] = gap
        if self._moving.size:
            gap = np.linalg.norm(xpos[self._ma] - xpos[self._mb], axis=1) - self._mr
            if self._any_unbounded:
                gap[self._unbounded] = -np.inf
            bound[self._moving] = gap
        return bound
