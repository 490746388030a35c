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

The minimum is the exhaustive one: what measuring every pair at every observed step with
``mj_geomDistance(..., distmax)`` gives, the first step it is reached at, and of the pairs
reaching it at that step the first (robot geom id, then world geom id). A broad phase of
bounding volumes (:class:`_Bounds`, a few array operations per step whatever the number of
pairs) finds the pairs that could reach the minimum; only those are measured.
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Iterable, Sequence
from functools import lru_cache
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events.collision import body_names, geom_names
from harness.events.errors import LoggerConfigError
from harness.events.events import Event
from harness.events.logger import StepContext, period_ns_from_hz

__all__ = ["Clearance", "ClearanceLogger"]

_TOUCHING = 1e-6  # metres: a pair this close at the start is resting, not a margin
_APART = 1e-3  # metres: a pair whose bound says at least this is not resting (not measured)
_SLACK = 1e-9  # metres: pairs bounded within this of the minimum are measured (rounding)
_FEW = 4  # candidate pairs measured in pair order; more: nearest bound first


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
        self._bodies = bodies = body_names(model)
        self._geoms = geoms = geom_names(model)
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
        self._pairs: npt.NDArray[np.intp] = _pairs(model, robot, bodies, geoms, list(ignore))
        self._started = False
        self._bounds = _Bounds(None, None, self._pairs)
        self._a: list[int] = []
        self._b: list[int] = []
        self._data: mujoco.MjData | None = None
        self._xpos = np.zeros((0, 3))
        self.minimum = Clearance(self.distmax, -1, "", "")
        """The smallest clearance so far (see :class:`Clearance`)."""
        self._kept: list[tuple[int, npt.NDArray[np.float64], npt.NDArray[np.float64]]] = []

    @property
    def name(self) -> str:
        return self._name

    @property
    def period_ns(self) -> int:
        return self._period

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """Measure this step's clearance (no events)."""
        if not self._started:
            self._start(ctx)
        if not self._a:
            return []
        if ctx.data is not self._data:  # a view of the data's buffer: valid while it lives
            self._data, self._xpos = ctx.data, ctx.data.geom_xpos
        best = self.minimum.distance
        # every pair that may reach the minimum (a bound <= 0 may hide an overlap: measured
        # below a best <= 0; with best > 0 it is below best anyway)
        near = self._bounds.near(self._xpos, max(best + _SLACK, 0.0))
        if not near.size:
            return []
        model, data, distmax = ctx.model, ctx.data, self.distmax
        pa, pb = self._a, self._b
        found = -1
        if near.size <= _FEW:  # measured in pair order: of equal distances the first stays
            for i in near.tolist():
                d = mujoco.mj_geomDistance(model, data, pa[i], pb[i], distmax, None)
                if d < best:
                    best, found = d, i
        else:  # nearest bound first: the others are left once the minimum is below them
            low = self._bounds.lower_of(near)
            for bound, i in sorted(zip(low.tolist(), near.tolist(), strict=True)):
                if bound > best + _SLACK and bound > 0.0:
                    break
                d = mujoco.mj_geomDistance(model, data, pa[i], pb[i], distmax, None)
                if d < best or (d == best and 0 <= i < found):  # ties: the first pair
                    best, found = d, i
        if found >= 0:
            ga, gb = pa[found], pb[found]
            body = model.geom_bodyid
            self.minimum = Clearance(
                float(best),
                ctx.step,
                self._bodies[body[ga]],
                self._bodies[body[gb]],
                self._geoms[ga],
                self._geoms[gb],
            )
        return []

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        return []

    def keep(self, ctx: StepContext) -> None:
        """:meth:`observe` later: keep this step's geom poses (the first observed step is
        observed now); :meth:`settle` measures every kept step in one pass. The minimum is
        the one :meth:`observe` at each step would have found: the smallest distance, of
        equal ones the earliest step, then the first pair (every pair that could reach it is
        measured, from the same poses)."""
        if not self._started:
            self.observe(ctx)
            return
        if self._a:
            data = ctx.data
            self._kept.append((ctx.step, data.geom_xpos.copy(), data.geom_xmat.copy()))

    def settle(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Measure the steps :meth:`keep` kept (see there); ``model``, ``data``: the run's
        (each pair is measured at its kept poses in ``data``, whose geom poses are put back
        after)."""
        kept, self._kept = self._kept, []
        if not kept or not self._a:
            return
        xpos = np.stack([x for _, x, _ in kept])
        low = self._bounds.lower_many(xpos)  # steps x pairs
        best = self.minimum.distance
        flat = low.reshape(-1)
        # only what could beat the minimum so far, by bound, then step, then pair
        maybe = np.flatnonzero((flat <= best + _SLACK) | (flat <= 0.0))
        order = maybe[np.argsort(flat[maybe], kind="stable")]
        bounds = flat[order].tolist()
        saved_xpos, saved_xmat = data.geom_xpos.copy(), data.geom_xmat.copy()
        pa, pb, distmax = self._a, self._b, self.distmax
        npairs = len(pa)
        found: tuple[int, int] | None = None
        xpos, xmat = data.geom_xpos, data.geom_xmat
        try:
            for bound, index in zip(bounds, order.tolist(), strict=True):
                if bound > best + _SLACK and bound > 0.0:
                    break
                row, i = divmod(index, npairs)
                _, positions, frames = kept[row]
                ga, gb = pa[i], pb[i]
                xpos[ga], xpos[gb] = positions[ga], positions[gb]
                xmat[ga], xmat[gb] = frames[ga], frames[gb]
                d = mujoco.mj_geomDistance(model, data, ga, gb, distmax, None)
                if d < best or (d == best and found is not None and (row, i) < found):
                    best, found = d, (row, i)
        finally:
            xpos[:], xmat[:] = saved_xpos, saved_xmat
        if found is not None:
            row, i = found
            ga, gb = pa[i], pb[i]
            body = model.geom_bodyid
            self.minimum = Clearance(
                float(best),
                kept[row][0],
                self._bodies[body[ga]],
                self._bodies[body[gb]],
                self._geoms[ga],
                self._geoms[gb],
            )

    def _start(self, ctx: StepContext) -> None:
        """Leave out the pairs resting at the first observed step, read the fixed geoms'
        poses (:class:`_Bounds`)."""
        self._started = True
        model, data = ctx.model, ctx.data
        pairs = self._pairs
        bounds = _Bounds(model, data, pairs)
        if len(pairs):
            # a pair bounded at least _APART away is not resting: not measured
            keep = bounds.lower(data.geom_xpos) > _APART
            for i in (~keep).nonzero()[0].tolist():
                a, b = int(pairs[i, 0]), int(pairs[i, 1])
                keep[i] = mujoco.mj_geomDistance(model, data, a, b, _TOUCHING * 2, None) > _TOUCHING
            if not keep.all():
                self._pairs = pairs = pairs[keep]
                bounds = bounds.subset(keep)
        self._bounds = bounds
        self._a, self._b = pairs[:, 0].tolist(), pairs[:, 1].tolist()


def _pairs(
    model: mujoco.MjModel,
    robot: set[int],
    bodies: list[str],
    geoms: list[str],
    ignore: list[tuple[str, str]],
) -> npt.NDArray[np.intp]:
    """The (robot geom, world geom) pairs that can collide (``contype``/``conaffinity``) and
    that no ``ignore`` pattern pair names (either order; a pattern names a geom when it
    matches the geom's or its body's name), by robot geom then world geom id. ``bodies`` and
    ``geoms``: the model's names (:func:`body_names`, :func:`geom_names`)."""
    return _pairs_of(
        tuple(bodies),
        tuple(geoms),
        np.asarray(model.geom_bodyid, dtype=np.int32).tobytes(),
        np.asarray(model.geom_contype, dtype=np.int32).tobytes(),
        np.asarray(model.geom_conaffinity, dtype=np.int32).tobytes(),
        tuple(sorted(robot)),
        tuple((str(first), str(second)) for first, second in ignore),
    )


@lru_cache(maxsize=64)
def _pairs_of(
    bodies: tuple[str, ...],
    geoms: tuple[str, ...],
    body_of_bytes: bytes,
    contype_bytes: bytes,
    conaffinity_bytes: bytes,
    robot: tuple[int, ...],
    ignore: tuple[tuple[str, str], ...],
) -> npt.NDArray[np.intp]:
    """:func:`_pairs` as a function of everything it reads, kept for the next model with the
    same names, bodies and collision masks (a warm world's next example; read only)."""
    body_of = np.frombuffer(body_of_bytes, dtype=np.int32)
    contype = np.frombuffer(contype_bytes, dtype=np.int32)
    conaffinity = np.frombuffer(conaffinity_bytes, dtype=np.int32)
    flags = np.zeros(len(bodies), dtype=bool)
    flags[list(robot)] = True
    ours = flags[body_of]
    mine, theirs = np.flatnonzero(ours), np.flatnonzero(~ours)
    ok = ((contype[mine, None] & conaffinity[None, theirs]) != 0) | (
        (contype[None, theirs] & conaffinity[mine, None]) != 0
    )
    matches: dict[str, npt.NDArray[np.bool_]] = {}

    def named(pattern: str) -> npt.NDArray[np.bool_]:
        """Per geom: whether ``pattern`` matches its name or its body's."""
        if pattern not in matches:
            body = [fnmatch.fnmatchcase(n, pattern) for n in bodies]
            matches[pattern] = np.array(
                [
                    body[b] or fnmatch.fnmatchcase(g, pattern)
                    for b, g in zip(body_of.tolist(), geoms, strict=True)
                ],
                dtype=bool,
            ).reshape(-1)
        return matches[pattern]

    for first, second in ignore:
        x, y = named(first), named(second)
        ok &= ~((x[mine, None] & y[None, theirs]) | (y[mine, None] & x[None, theirs]))
    a, b = np.nonzero(ok)
    out = np.empty((len(a), 2), dtype=np.intp)
    out[:, 0], out[:, 1] = mine[a], theirs[b]
    out.setflags(write=False)
    return out


_PLANE_DEPTH = 1e4  # metres: a plane bounds the half-space below it, as a box this deep
_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
_DENSE_LIMIT = 1 << 16  # entries of the one matrix of the broad phase (else per pair)


class _Bounds:
    """Lower bounds of the pairs' distances from geom positions (the broad phase).

    A pair whose other geom is fixed in the world (welded to it, not mocap) is bounded by the
    distance from the robot geom's bounding sphere to the other geom's bounding box (MuJoCo's
    ``geom_aabb`` in the geom's frame; a plane: the half-space below it), read once; other
    pairs by their two bounding spheres (0 radius, a plane: unbounded: ``-inf``). A positive
    bound is a true lower bound of the distance; one <= 0 says the volumes may overlap (an
    overlap's depth is not bounded: such a pair is measured whatever the minimum).

    Both are one affine map of the geoms' positions per pair (into the fixed box's frame, or
    the difference of the two centres), a box's half sizes (zero: a sphere's centre) and a
    radius: with few pairs, one matrix over the positions of the geoms read (a range of ids:
    the robot's are consecutive), else per pair.
    """

    def __init__(
        self,
        model: mujoco.MjModel | None,
        data: mujoco.MjData | None,
        pairs: npt.NDArray[np.intp],
    ) -> None:
        n = self._n = len(pairs)
        self._dense: npt.NDArray[np.float64] | None = None
        self._limit = math.nan  # the limit self._reach was made for
        self._reach = self._s = np.zeros(0)
        if model is None or data is None or not n:
            return
        a, b = pairs[:, 0], pairs[:, 1]
        rbound = np.asarray(model.geom_rbound, dtype=np.float64)
        body = np.asarray(model.geom_bodyid)
        fixed = (np.asarray(model.body_weldid)[body[b]] == 0) & (
            np.asarray(model.body_mocapid)[body[b]] < 0
        )
        rot = np.zeros((n, 3, 3))
        rot[:] = np.eye(3)
        offset = np.zeros((n, 3))
        half = np.zeros((n, 3))
        radius = rbound[a] + np.where(fixed, 0.0, rbound[b])
        # 0 radius (a plane): unbounded, always measured
        radius[(rbound[a] == 0) | (~fixed & (rbound[b] == 0))] = np.inf
        gb = b[fixed]
        if gb.size:
            frame = np.asarray(data.geom_xmat)[gb].reshape(-1, 3, 3)
            aabb = np.asarray(model.geom_aabb)[gb].reshape(-1, 6)
            center, size = aabb[:, :3].copy(), aabb[:, 3:].copy()
            plane = np.asarray(model.geom_type)[gb] == _PLANE  # an int: an enum compares slowly
            center[plane] = (0.0, 0.0, -_PLANE_DEPTH)
            size[plane] = (np.inf, np.inf, _PLANE_DEPTH)
            world = np.asarray(data.geom_xpos)[gb] + np.einsum("kij,kj->ki", frame, center)
            inverse = frame.transpose(0, 2, 1)
            rot[fixed] = inverse
            offset[fixed] = -np.einsum("kij,kj->ki", inverse, world)
            half[fixed] = size
        self._offset = offset.reshape(-1)
        self._half = half.reshape(-1)
        self._radius = radius
        self._ones = np.ones(3)
        # the matrix's columns: the geoms it reads (the robot's, the moving others), a range
        moving = np.flatnonzero(~fixed)
        used = np.concatenate([a, b[moving]])
        first, end = int(used.min()), int(used.max()) + 1
        self._span = slice(first, end)
        self._a, self._b = a, b
        self._rot = rot
        self._minus = (~fixed).astype(np.float64)[:, None]
        if 9 * n * (end - first) <= _DENSE_LIMIT:
            dense = np.zeros((n, 3, end - first, 3))
            dense[np.arange(n), :, a - first, :] = rot
            dense[moving, :, b[moving] - first, :] = -np.eye(3)
            self._dense = dense.reshape(3 * n, 3 * (end - first))

    def subset(self, keep: npt.NDArray[np.bool_]) -> _Bounds:
        """These bounds of the pairs ``keep`` selects."""
        out = _Bounds(None, None, np.zeros((int(keep.sum()), 2), dtype=np.intp))
        rows = np.repeat(keep, 3)
        out._offset, out._half = self._offset[rows], self._half[rows]
        out._radius, out._ones = self._radius[keep], self._ones
        out._span = self._span
        out._a, out._b = self._a[keep], self._b[keep]
        out._rot, out._minus = self._rot[keep], self._minus[keep]
        if self._dense is not None:
            out._dense = self._dense[rows]
        return out

    def lower(self, xpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Per pair: a lower bound of its distance now (``xpos``: ``data.geom_xpos``)."""
        if not self._n:
            return np.zeros(0)
        gap: npt.NDArray[np.float64] = np.sqrt(self._squared(xpos))
        gap -= self._radius
        return gap

    def lower_many(self, xpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """:meth:`lower` at each of several instants (``xpos``: their ``geom_xpos``, stacked):
        one row of bounds per instant."""
        steps = len(xpos)
        if not self._n:
            return np.zeros((steps, 0))
        # per pair (not the one matrix: at this size a matrix product runs on BLAS threads,
        # which spin on the cores parallel workers run on, and is mostly zeros)
        x, rot = xpos[:, self._a], self._rot  # steps x pairs x 3
        moved: npt.NDArray[np.float64] = np.empty(x.shape)
        for i in range(3):  # the 3x3 product written out: ~5x an einsum's pace here
            moved[..., i] = (
                rot[:, i, 0] * x[..., 0] + rot[:, i, 1] * x[..., 1] + rot[:, i, 2] * x[..., 2]
            )
        moved -= xpos[:, self._b] * self._minus[None]
        q = moved.reshape(steps, -1)
        q += self._offset
        np.abs(q, out=q)
        q -= self._half
        np.maximum(q, 0.0, out=q)
        q *= q
        gap: npt.NDArray[np.float64] = np.sqrt(q.reshape(steps, -1, 3).sum(axis=2))
        gap -= self._radius
        return gap

    def near(self, xpos: npt.NDArray[np.float64], limit: float) -> npt.NDArray[np.intp]:
        """The pairs whose bound now is at most ``limit`` (>= 0), by index: a bound is
        ``sqrt(s) - r``, so ``s <= (limit + r)^2`` (no square root per pair; the right side
        is kept while the limit stays). :meth:`lower_of` gives their bounds."""
        if not self._n:
            return np.zeros(0, dtype=np.intp)
        if limit != self._limit:
            self._limit = limit
            self._reach = reach = self._radius + limit  # a plane's: inf
            reach *= reach
        found: npt.NDArray[np.intp] = (self._squared(xpos) <= self._reach).nonzero()[0]
        return found

    def lower_of(self, pairs: npt.NDArray[np.intp]) -> npt.NDArray[np.float64]:
        """The bounds of ``pairs`` at the positions of the last :meth:`near`."""
        gap: npt.NDArray[np.float64] = np.sqrt(self._s[pairs])
        gap -= self._radius[pairs]
        return gap

    def _squared(self, xpos: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Per pair: the squared distance from the robot geom's centre to the other's box
        (kept for :meth:`lower_of`)."""
        if self._dense is not None:
            q = self._dense @ xpos[self._span].reshape(-1)
        else:
            q = np.matmul(self._rot, xpos[self._a][:, :, None]).reshape(-1)
            q -= (xpos[self._b] * self._minus).reshape(-1)
        q += self._offset
        np.abs(q, out=q)
        q -= self._half
        np.maximum(q, 0.0, out=q)
        q *= q
        self._s = q.reshape(-1, 3) @ self._ones
        return self._s
