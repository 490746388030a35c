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
        self._rbound = np.asarray(model.geom_rbound, dtype=np.float64)
        self._started = False
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
        pairs = self._pairs
        if not len(pairs):
            return []
        xpos = ctx.data.geom_xpos
        a, b = pairs[:, 0], pairs[:, 1]
        rb_a, rb_b = self._rbound[a], self._rbound[b]
        bound = np.linalg.norm(xpos[a] - xpos[b], axis=1) - rb_a - rb_b
        bound[(rb_a == 0) | (rb_b == 0)] = -np.inf  # planes: unbounded, always measured
        best = self.minimum.distance
        for i in np.argsort(bound, kind="stable"):
            if bound[i] >= best:
                break
            ga, gb = int(a[i]), int(b[i])
            d = mujoco.mj_geomDistance(ctx.model, ctx.data, ga, gb, best, None)
            if d < best:
                best = d
                body = ctx.model.geom_bodyid
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
