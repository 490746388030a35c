"""Collision begin/end tracking per body pair, debounced, and near-miss tracking (pure: no I/O).

A body pair is *in contact* at an observed step when at least one of its contacts touches
(penetration >= 0, or a non-zero normal force) with a normal force of at least ``min_force``
and the pair is allowed by the filter matrix. Contact between a box and a table chatters (the
pair toggles every few steps), so a pair *ends* only after ``debounce_steps`` consecutive
observations without contact; a contact that comes back within that window continues the same
episode.

Every transition is stamped with the step at which the tracker learns of it (so stamps never go
backwards); an end also carries the episode's exact ``begin_step`` and ``end_step`` (the first
observation without contact). Ids are MuJoCo body and geom ids; names are the caller's concern.
Pairs are ordered ``body1 < body2``; a contact normal is flipped when its bodies are swapped,
so it always points from ``body1`` to ``body2``.
"""

from __future__ import annotations

from collections.abc import Iterable, Set
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sim.contacts import ContactSet

__all__ = [
    "CollisionTracker",
    "CollisionTransition",
    "NearMissRecord",
    "NearMissTracker",
    "allowed_pairs",
    "near_miss_candidates",
    "subtree_bodies",
]

Vec3 = tuple[float, float, float]
BoolMatrix = npt.NDArray[np.bool_]
_SMALL = 48  # contacts up to which grouping runs in plain Python
_Group = tuple[int, float, float]  # a pair's deepest contact's index, its max force, that depth


def subtree_bodies(model: mujoco.MjModel, root: int) -> frozenset[int]:
    """Ids of ``root`` and every body below it in the kinematic tree."""
    parents = np.asarray(model.body_parentid)
    inside = np.zeros(model.nbody, dtype=bool)
    inside[root] = True
    # Bodies are numbered parent-before-child, so one forward pass suffices.
    for body in range(root + 1, model.nbody):
        if inside[parents[body]]:
            inside[body] = True
    return frozenset(int(b) for b in np.flatnonzero(inside))


def allowed_pairs(
    nbody: int,
    *,
    robot_bodies: Iterable[int] = (),
    self_contacts: bool = True,
    robot_vs_world_only: bool = False,
    ignore: Iterable[tuple[int, int]] = (),
) -> BoolMatrix:
    """A symmetric ``(nbody, nbody)`` matrix: True where a body pair is reported.

    Pair classes: *self* (both bodies are the robot's), *robot-world* (one is), *environment*
    (neither). Self pairs are reported when ``self_contacts``; environment pairs unless
    ``robot_vs_world_only`` (which also drops self pairs). ``ignore`` pairs are never reported.
    """
    robot = np.zeros(nbody, dtype=bool)
    robot[list(robot_bodies)] = True
    both = robot[:, None] & robot[None, :]
    neither = ~robot[:, None] & ~robot[None, :]
    allowed = np.ones((nbody, nbody), dtype=bool)
    if not self_contacts or robot_vs_world_only:
        allowed &= ~both
    if robot_vs_world_only:
        allowed &= ~neither
    for a, b in ignore:
        allowed[a, b] = allowed[b, a] = False
    return allowed


@dataclass(frozen=True)
class CollisionTransition:
    """A body pair starting (``kind == "begin"``) or ending (``"end"``) contact.

    ``step``/``sim_time_ns``: when the tracker emitted it (for an end, ``debounce_steps``
    observations after ``end_step``). Peaks are over the episode so far; ``geom1``/``geom2``,
    ``position`` and ``normal`` are those of the deepest contact seen. ``at_finish``: the episode
    was still open when the run ended (``end_step`` is then the last observed step).
    """

    kind: Literal["begin", "end"]
    step: int
    sim_time_ns: int
    body1: int
    body2: int
    geom1: int
    geom2: int
    penetration: float
    normal_force: float
    position: Vec3
    normal: Vec3
    begin_step: int
    begin_time_ns: int
    end_step: int = -1
    end_time_ns: int = -1
    at_finish: bool = False

    @property
    def duration_ns(self) -> int:
        """Sim time from the first observation with contact to the first without (0 on begin)."""
        return self.end_time_ns - self.begin_time_ns if self.kind == "end" else 0


class _Episode:
    __slots__ = (
        "absent",
        "begin_step",
        "begin_time_ns",
        "body1",
        "body2",
        "end_step",
        "end_time_ns",
        "force",
        "geom1",
        "geom2",
        "normal",
        "penetration",
        "position",
    )

    def __init__(self, body1: int, body2: int, step: int, time_ns: int) -> None:
        self.body1 = body1
        self.body2 = body2
        self.begin_step = step
        self.begin_time_ns = time_ns
        self.absent = 0
        self.end_step = -1
        self.end_time_ns = -1
        self.geom1 = -1
        self.geom2 = -1
        self.penetration = -np.inf
        self.force = 0.0
        self.position: Vec3 = (0.0, 0.0, 0.0)
        self.normal: Vec3 = (0.0, 0.0, 0.0)

    def transition(
        self,
        kind: Literal["begin", "end"],
        step: int,
        time_ns: int,
        at_finish: bool = False,
    ) -> CollisionTransition:
        return CollisionTransition(
            kind=kind,
            step=step,
            sim_time_ns=time_ns,
            body1=self.body1,
            body2=self.body2,
            geom1=self.geom1,
            geom2=self.geom2,
            penetration=max(float(self.penetration), 0.0),
            normal_force=self.force,
            position=self.position,
            normal=self.normal,
            begin_step=self.begin_step,
            begin_time_ns=self.begin_time_ns,
            end_step=self.end_step,
            end_time_ns=self.end_time_ns,
            at_finish=at_finish,
        )


class CollisionTracker:
    """Begin/end of contact per body pair from one :class:`ContactSet` per observed step.

    ``allowed``: the filter from :func:`allowed_pairs` (None: every pair); ``min_force``:
    contacts with a smaller normal force do not count; ``debounce_steps`` (>= 1): observations
    without contact before a pair ends.
    """

    def __init__(
        self,
        *,
        debounce_steps: int = 1,
        min_force: float = 0.0,
        allowed: BoolMatrix | None = None,
    ) -> None:
        if debounce_steps < 1:
            raise ValueError(f"debounce_steps must be >= 1, got {debounce_steps}")
        self.debounce_steps = debounce_steps
        self.min_force = min_force
        self.allowed = allowed
        self._allowed_rows: list[list[bool]] | None = None
        self._open: dict[tuple[int, int], _Episode] = {}
        self._seen: dict[tuple[int, int], _Group] = {}

    @property
    def open_pairs(self) -> frozenset[tuple[int, int]]:
        """Pairs in an episode now (including those within the debounce window)."""
        return frozenset(self._open)

    def is_open(self, key: tuple[int, int]) -> bool:
        """Whether the pair ``key`` (``body1 < body2``) is in an episode now."""
        return key in self._open

    def open_keys(self) -> Set[tuple[int, int]]:
        """The pairs in an episode now, as a live view (no copy: read it before the next
        :meth:`update`)."""
        return self._open.keys()

    @property
    def touching(self) -> frozenset[tuple[int, int]]:
        """Pairs in contact at the last observed step."""
        return frozenset(self._seen)

    def update(
        self, step: int, sim_time_ns: int, contacts: ContactSet
    ) -> list[CollisionTransition]:
        """Observe one step; returns the ends (first) and begins it causes, each by pair.

        A step whose pairs are the open ones (nothing begins or ends) costs one pass over
        its contacts and one over its pairs; a pair's deepest contact's pose is read only
        when its penetration peaks."""
        opened = self._open
        if contacts.size == 0 and not opened:
            self._seen = {}
            return []
        seen = self._group(contacts)
        self._seen = seen
        ends: list[CollisionTransition] = []
        if len(opened) > len(seen) or not opened.keys() <= seen.keys():
            for key in sorted(opened.keys() - seen.keys()):
                episode = opened[key]
                if episode.absent == 0:
                    episode.end_step = step
                    episode.end_time_ns = sim_time_ns
                episode.absent += 1
                if episode.absent >= self.debounce_steps:
                    del opened[key]
                    ends.append(episode.transition("end", step, sim_time_ns))
        fresh: list[tuple[int, int]] = []
        for key, (index, force, depth) in seen.items():
            found = opened.get(key)
            if found is None:
                episode = opened[key] = _Episode(key[0], key[1], step, sim_time_ns)
                fresh.append(key)
            else:
                episode = found
                if episode.absent:
                    episode.absent = 0
                    episode.end_step = episode.end_time_ns = -1
            if force > episode.force:
                episode.force = force
            if depth > episode.penetration:
                episode.penetration = depth
                p = contacts.position[index].tolist()
                n = contacts.normal[index].tolist()
                g1, g2 = int(contacts.geom1[index]), int(contacts.geom2[index])
                episode.position = (p[0], p[1], p[2])
                if int(contacts.body1[index]) != episode.body1:
                    episode.geom1, episode.geom2 = g2, g1
                    episode.normal = (-n[0], -n[1], -n[2])
                else:
                    episode.geom1, episode.geom2 = g1, g2
                    episode.normal = (n[0], n[1], n[2])
        if not fresh:
            return ends
        fresh.sort()
        return ends + [opened[key].transition("begin", step, sim_time_ns) for key in fresh]

    def finish(self, step: int, sim_time_ns: int) -> list[CollisionTransition]:
        """End every open episode (the run is over); ``at_finish`` is set on each."""
        out: list[CollisionTransition] = []
        for key in sorted(self._open):
            episode = self._open[key]
            if episode.absent == 0:
                episode.end_step = step
                episode.end_time_ns = sim_time_ns
            out.append(episode.transition("end", step, sim_time_ns, at_finish=True))
        self._open.clear()
        self._seen = {}
        return out

    def _group(self, contacts: ContactSet) -> dict[tuple[int, int], _Group]:
        """``{(body1, body2): (index of the deepest counting contact, max normal force, its
        depth)}``; the first of equally deep contacts."""
        if contacts.size == 0:
            return {}
        if contacts.size <= _SMALL:
            return self._group_small(contacts)
        keep = (contacts.depth >= 0.0) | (contacts.normal_force > 0.0)
        if self.min_force > 0.0:
            keep &= contacts.normal_force >= self.min_force
        if self.allowed is not None:
            keep &= self.allowed[contacts.body1, contacts.body2]
        index = np.flatnonzero(keep)
        if index.size == 0:
            return {}
        b1 = contacts.body1[index].astype(np.int64)
        b2 = contacts.body2[index].astype(np.int64)
        lo = np.minimum(b1, b2)
        hi = np.maximum(b1, b2)
        key = (lo << 32) | hi
        if index.size == 1:
            i = int(index[0])
            return {
                (int(lo[0]), int(hi[0])): (
                    i,
                    float(contacts.normal_force[i]),
                    float(contacts.depth[i]),
                )
            }
        order = np.lexsort((-contacts.depth[index], key))
        key_sorted = key[order]
        starts = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
        force_max = np.maximum.reduceat(contacts.normal_force[index][order], starts)
        deepest = index[order[starts]]
        keys = key_sorted[starts]
        return {
            (k >> 32, k & 0xFFFFFFFF): (i, f, d)
            for k, i, f, d in zip(
                keys.tolist(),
                deepest.tolist(),
                force_max.tolist(),
                contacts.depth[deepest].tolist(),
                strict=True,
            )
        }

    def _group_small(self, contacts: ContactSet) -> dict[tuple[int, int], _Group]:
        # Same result as the array path; plain Python is faster for a few contacts.
        if self.allowed is not None and self._allowed_rows is None:
            self._allowed_rows = self.allowed.tolist()
        rows = self._allowed_rows
        min_force = self.min_force
        depth = contacts.depth.tolist()
        force = contacts.normal_force.tolist()
        out: dict[tuple[int, int], _Group] = {}
        for i, (a, b) in enumerate(
            zip(contacts.body1.tolist(), contacts.body2.tolist(), strict=True)
        ):
            d, f = depth[i], force[i]
            if not (d >= 0.0 or f > 0.0) or f < min_force:
                continue
            if rows is not None and not rows[a][b]:
                continue
            key = (a, b) if a < b else (b, a)
            best = out.get(key)
            if best is None:
                out[key] = (i, f, d)
            elif d > best[2]:
                out[key] = (i, f if f > best[1] else best[1], d)
            elif f > best[1]:
                out[key] = (best[0], f, best[2])
        return out


def near_miss_candidates(model: mujoco.MjModel, allowed: BoolMatrix) -> npt.NDArray[np.int32]:
    """Geom pairs ``(P, 2)`` worth a distance query: on allowed body pairs, on different bodies,
    not parent and child, not both world-fixed, not excluded, and able to collide
    (``contype``/``conaffinity``)."""
    ngeom = model.ngeom
    if ngeom < 2:
        return np.zeros((0, 2), dtype=np.int32)
    g1, g2 = np.triu_indices(ngeom, k=1)
    body = np.asarray(model.geom_bodyid)
    b1, b2 = body[g1], body[g2]
    parent = np.asarray(model.body_parentid)
    weld = np.asarray(model.body_weldid)
    contype = np.asarray(model.geom_contype)
    conaff = np.asarray(model.geom_conaffinity)
    keep = allowed[b1, b2] & (b1 != b2)
    keep &= (parent[b1] != b2) & (parent[b2] != b1)
    keep &= ~((weld[b1] == 0) & (weld[b2] == 0))
    keep &= ((contype[g1] & conaff[g2]) != 0) | ((contype[g2] & conaff[g1]) != 0)
    if model.nexclude:
        signatures = set(np.asarray(model.exclude_signature).tolist())
        lo, hi = np.minimum(b1, b2), np.maximum(b1, b2)
        signature = (lo << 16) + hi
        keep &= ~np.isin(signature, list(signatures))
    return np.stack([g1[keep], g2[keep]], axis=1).astype(np.int32)


@dataclass(frozen=True)
class NearMissRecord:
    """A body pair came within the near-miss distance and left again without touching.

    ``step``/``sim_time_ns``: when emitted; ``closest_step``: the observation of closest
    approach, where ``distance``, the geoms, ``position`` (midpoint of the closest points) and
    ``normal`` (unit, from ``geom1`` towards ``geom2``) were taken; ``begin_step``/``end_step``:
    first observation within the distance and first one outside it.
    """

    step: int
    sim_time_ns: int
    body1: int
    body2: int
    geom1: int
    geom2: int
    distance: float
    position: Vec3
    normal: Vec3
    closest_step: int
    closest_time_ns: int
    begin_step: int
    end_step: int
    at_finish: bool = False


class _Approach:
    __slots__ = (
        "absent",
        "begin_step",
        "closest_step",
        "closest_time_ns",
        "distance",
        "end_step",
        "geom1",
        "geom2",
        "normal",
        "position",
        "touched",
    )

    def __init__(self, step: int) -> None:
        self.begin_step = step
        self.end_step = -1
        self.absent = 0
        self.touched = False
        self.distance = np.inf
        self.closest_step = step
        self.closest_time_ns = 0
        self.geom1 = self.geom2 = -1
        self.position: Vec3 = (0.0, 0.0, 0.0)
        self.normal: Vec3 = (0.0, 0.0, 0.0)


class NearMissTracker:
    """Near misses from ``mj_geomDistance`` (read-only: the physics is not changed).

    ``candidates``: geom pairs from :func:`near_miss_candidates`; a bounding-sphere test skips
    pairs that are clearly apart before the exact distance query. An approach touched by a
    contact (``touching`` pairs passed to :meth:`update`) is a collision, not a near miss.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        candidates: npt.NDArray[np.int32],
        *,
        distance: float,
        debounce_steps: int = 1,
    ) -> None:
        if distance <= 0.0:
            raise ValueError(f"near-miss distance must be > 0, got {distance}")
        if debounce_steps < 1:
            raise ValueError(f"debounce_steps must be >= 1, got {debounce_steps}")
        self.distance = distance
        self.debounce_steps = debounce_steps
        self._g1 = candidates[:, 0].astype(np.intp)
        self._g2 = candidates[:, 1].astype(np.intp)
        body = np.asarray(model.geom_bodyid)
        self._b1 = body[self._g1]
        self._b2 = body[self._g2]
        rbound = np.asarray(model.geom_rbound, dtype=np.float64)
        # rbound 0 marks planes (unbounded): always query them.
        unbounded = (rbound[self._g1] == 0.0) | (rbound[self._g2] == 0.0)
        self._reach = np.where(unbounded, np.inf, rbound[self._g1] + rbound[self._g2] + distance)
        self._fromto = np.zeros(6, dtype=np.float64)
        self._open: dict[tuple[int, int], _Approach] = {}

    def update(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        step: int,
        sim_time_ns: int,
        touching: frozenset[tuple[int, int]] = frozenset(),
    ) -> list[NearMissRecord]:
        """Observe one step (after ``mj_step``: geom poses of the step's start, like contacts)."""
        near: dict[tuple[int, int], tuple[float, int, int, Vec3, Vec3]] = {}
        if self._g1.size:
            xpos = data.geom_xpos
            gap = np.linalg.norm(xpos[self._g1] - xpos[self._g2], axis=1)
            for p in np.flatnonzero(gap < self._reach).tolist():
                g1, g2 = int(self._g1[p]), int(self._g2[p])
                dist = mujoco.mj_geomDistance(model, data, g1, g2, self.distance, self._fromto)
                if dist >= self.distance:
                    continue
                b1, b2 = int(self._b1[p]), int(self._b2[p])
                if b1 > b2:
                    b1, b2, g1, g2 = b2, b1, g2, g1
                    a, b = self._fromto[3:], self._fromto[:3]
                else:
                    a, b = self._fromto[:3], self._fromto[3:]
                key = (b1, b2)
                if key in near and near[key][0] <= dist:
                    continue
                mid = (a + b) / 2.0
                direction = b - a
                norm = float(np.linalg.norm(direction))
                unit = direction / norm if norm > 0.0 else direction
                near[key] = (
                    float(dist),
                    g1,
                    g2,
                    (float(mid[0]), float(mid[1]), float(mid[2])),
                    (float(unit[0]), float(unit[1]), float(unit[2])),
                )
        out: list[NearMissRecord] = []
        for key in sorted(self._open.keys() - near.keys()):
            approach = self._open[key]
            if approach.absent == 0:
                approach.end_step = step
            approach.absent += 1
            if key in touching:
                approach.touched = True
            if approach.absent >= self.debounce_steps:
                del self._open[key]
                if not approach.touched:
                    out.append(self._record(key, approach, step, sim_time_ns))
        for key in sorted(near):
            dist, g1, g2, closest_mid, closest_dir = near[key]
            approach_or_none = self._open.get(key)
            if approach_or_none is None:
                approach_or_none = self._open[key] = _Approach(step)
            approach = approach_or_none
            approach.absent = 0
            approach.end_step = -1
            if dist <= 0.0 or key in touching:
                approach.touched = True
            if dist < approach.distance:
                approach.distance = dist
                approach.closest_step = step
                approach.closest_time_ns = sim_time_ns
                approach.geom1, approach.geom2 = g1, g2
                approach.position, approach.normal = closest_mid, closest_dir
        return out

    def finish(self, step: int, sim_time_ns: int) -> list[NearMissRecord]:
        """Report every untouched open approach (the run is over)."""
        out = []
        for key in sorted(self._open):
            approach = self._open[key]
            if approach.end_step < 0:
                approach.end_step = step
            if not approach.touched:
                out.append(self._record(key, approach, step, sim_time_ns, at_finish=True))
        self._open.clear()
        return out

    @staticmethod
    def _record(
        key: tuple[int, int],
        approach: _Approach,
        step: int,
        sim_time_ns: int,
        at_finish: bool = False,
    ) -> NearMissRecord:
        return NearMissRecord(
            step=step,
            sim_time_ns=sim_time_ns,
            body1=key[0],
            body2=key[1],
            geom1=approach.geom1,
            geom2=approach.geom2,
            distance=float(approach.distance),
            position=approach.position,
            normal=approach.normal,
            closest_step=approach.closest_step,
            closest_time_ns=approach.closest_time_ns,
            begin_step=approach.begin_step,
            end_step=approach.end_step,
            at_finish=at_finish,
        )
