"""The collision logger: begin/end per body pair (debounced), filters, optional near misses.

The tracking itself is :mod:`harness.sim.collisions` (ids, no names); this logger turns its
transitions into :class:`CollisionBegin`/:class:`CollisionEnd`/:class:`NearMiss` events with
body and geom names.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from functools import lru_cache

import mujoco
import numpy as np
import numpy.typing as npt

from harness.events.errors import LoggerConfigError
from harness.events.events import CollisionBegin, CollisionEnd, Event, NearMiss
from harness.events.logger import StepContext
from harness.events.support import SupportClassifier
from harness.sim import (
    CollisionTracker,
    CollisionTransition,
    NearMissRecord,
    NearMissTracker,
    allowed_pairs,
    near_miss_candidates,
    subtree_bodies,
)

__all__ = ["CollisionLogger", "body_names", "geom_names"]


def body_names(model: mujoco.MjModel) -> list[str]:
    """Body names by id (``body<id>`` for unnamed bodies; body 0 is ``world``)."""
    return _names(model, model.name_bodyadr, "body")


def geom_names(model: mujoco.MjModel) -> list[str]:
    """Geom names by id (``geom<id>`` for unnamed geoms)."""
    return _names(model, model.name_geomadr, "geom")


def _names(model: mujoco.MjModel, addresses: npt.NDArray[np.int32], kind: str) -> list[str]:
    """Names read from the model's name buffer, ``<kind><id>`` for the unnamed (a
    ``model.body(i)`` accessor per name costs microseconds: every session's loggers ask)."""
    return list(_names_in(model.names, addresses.tobytes(), kind))


@lru_cache(maxsize=64)
def _names_in(raw: bytes, addresses: bytes, kind: str) -> tuple[str, ...]:
    """The names at ``addresses`` (int32) of a model's name buffer ``raw``: a function of
    the two, kept for the next model with the same names (a warm world's next example)."""
    return tuple(
        raw[start : raw.index(b"\0", start)].decode() or f"{kind}{i}"
        for i, start in enumerate(np.frombuffer(addresses, dtype=np.int32).tolist())
    )


class CollisionLogger:
    """Collision begin/end events per body pair, observed every step.

    The robot's bodies are ``robot_bodies`` (names) and/or the subtree of ``robot_root``;
    they decide what counts as the robot's contact with itself (``self_contacts``: reported
    or not; ``self_collision=`` is its earlier spelling, read with a warning) and what
    ``robot_vs_world_only`` keeps (only pairs of one robot body and one other body).
    ``ignore``: body-name pairs never reported (either order). ``min_force``: contacts below
    this normal force (N) do not count. ``debounce_steps``: steps without contact before a
    pair ends. ``near_miss_distance`` (m): also report pairs that come this close without
    touching (``mj_geomDistance``; the physics is not changed).

    Each begin and end says whether the pair's contacts were all *support* contacts of the
    robot (``support``: a wheel on the floor, a base resting on its floor; see
    :mod:`harness.events.support`); a logger without robot bodies marks none.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        robot_root: str | None = None,
        robot_bodies: Iterable[str] = (),
        self_contacts: bool = True,
        robot_vs_world_only: bool = False,
        ignore: Iterable[tuple[str, str]] = (),
        min_force: float = 0.0,
        debounce_steps: int = 5,
        near_miss_distance: float | None = None,
        name: str = "collisions",
        self_collision: bool | None = None,
    ) -> None:
        if self_collision is not None:
            warnings.warn(
                "CollisionLogger(self_collision=) is spelled self_contacts= now "
                "(self_collision is the robot's link-pair policy)",
                DeprecationWarning,
                stacklevel=2,
            )
            self_contacts = self_collision
        self._name = name
        self._bodies = body_names(model)
        self._geoms = geom_names(model)
        index = {n: i for i, n in enumerate(self._bodies)}

        def body(what: str, body_name: str) -> int:
            if body_name not in index:
                raise LoggerConfigError(
                    f"collision logger {name!r}: {what}: no body named {body_name!r}"
                )
            return index[body_name]

        robot: set[int] = set()
        if robot_root is not None:
            robot |= subtree_bodies(model, body("robot_root", robot_root))
        robot |= {body(f"robot_bodies[{i}]", b) for i, b in enumerate(robot_bodies)}
        robot.discard(0)
        if robot_vs_world_only and not robot:
            raise LoggerConfigError(
                f"collision logger {name!r}: robot_vs_world_only needs robot_root or robot_bodies"
            )
        pairs = []
        for i, pair in enumerate(ignore):
            if len(pair) != 2:
                raise LoggerConfigError(
                    f"collision logger {name!r}: ignore[{i}] must be two body names"
                )
            pairs.append((body(f"ignore[{i}]", pair[0]), body(f"ignore[{i}]", pair[1])))
        if min_force < 0:
            raise LoggerConfigError(f"collision logger {name!r}: min_force must be >= 0")
        if debounce_steps < 1:
            raise LoggerConfigError(f"collision logger {name!r}: debounce_steps must be >= 1")
        self.robot_bodies = frozenset(robot)
        allowed = allowed_pairs(
            model.nbody,
            robot_bodies=robot,
            self_contacts=self_contacts,
            robot_vs_world_only=robot_vs_world_only,
            ignore=pairs,
        )
        self._support = SupportClassifier(model, robot) if robot else None
        self._not_support: set[tuple[int, int]] = set()
        self._tracker = CollisionTracker(
            debounce_steps=debounce_steps, min_force=min_force, allowed=allowed
        )
        self._near: NearMissTracker | None = None
        if near_miss_distance is not None:
            if not near_miss_distance > 0:
                raise LoggerConfigError(
                    f"collision logger {name!r}: near_miss_distance must be > 0"
                )
            self._near = NearMissTracker(
                model,
                near_miss_candidates(model, allowed),
                distance=near_miss_distance,
                debounce_steps=debounce_steps,
            )

    @property
    def name(self) -> str:
        return self._name

    @property
    def period_ns(self) -> int:
        """Every step (debouncing counts steps)."""
        return 0

    def observe(self, ctx: StepContext) -> Sequence[Event]:
        """Ends and begins caused by this step's contacts, then near misses that closed."""
        transitions = self._tracker.update(ctx.step, ctx.sim_time_ns, ctx.contacts)
        self._note_support(ctx)
        events: list[Event] = [self._collision(t, ctx.robot) for t in transitions]
        if self._near is not None:
            records = self._near.update(
                ctx.model, ctx.data, ctx.step, ctx.sim_time_ns, self._tracker.open_pairs
            )
            events.extend(self._near_miss(r, ctx.robot) for r in records)
        return events

    def finish(self, ctx: StepContext) -> Sequence[Event]:
        """End every open contact and report every open untouched approach."""
        events: list[Event] = [
            self._collision(t, ctx.robot) for t in self._tracker.finish(ctx.step, ctx.sim_time_ns)
        ]
        if self._near is not None:
            records = self._near.finish(ctx.step, ctx.sim_time_ns)
            events.extend(self._near_miss(r, ctx.robot) for r in records)
        return events

    def _note_support(self, ctx: StepContext) -> None:
        """Remember the open pairs that had a contact other than a support contact."""
        contacts = ctx.contacts
        if self._support is not None:
            self._support.learn_floors(contacts)  # the first step observed: what it rests on
        if contacts.size == 0:
            return
        tracker = self._tracker
        if self._not_support.issuperset(tracker.open_keys()):
            return  # every open pair is known not to be support: nothing to learn
        touching = (contacts.depth >= 0.0) | (contacts.normal_force > 0.0)
        if self._support is not None:
            touching &= ~self._support.support(contacts)
        index = np.flatnonzero(touching)
        if index.size == 0:
            return
        b1 = contacts.body1[index].tolist()
        b2 = contacts.body2[index].tolist()
        for a, b in zip(b1, b2, strict=True):
            key = (a, b) if a <= b else (b, a)
            if tracker.is_open(key):
                self._not_support.add(key)

    def _is_support(self, t: CollisionTransition) -> bool:
        key = (t.body1, t.body2) if t.body1 <= t.body2 else (t.body2, t.body1)
        support = self._support is not None and key not in self._not_support
        if t.kind != "begin":
            self._not_support.discard(key)
        return support

    def _collision(self, t: CollisionTransition, robot: str) -> Event:
        support = self._is_support(t)
        if t.kind == "begin":
            return CollisionBegin(
                step=t.step,
                sim_time_ns=t.sim_time_ns,
                robot=robot,
                body1=self._bodies[t.body1],
                body2=self._bodies[t.body2],
                geom1=self._geoms[t.geom1],
                geom2=self._geoms[t.geom2],
                position=t.position,
                normal=t.normal,
                penetration=t.penetration,
                normal_force=t.normal_force,
                support=support,
            )
        return CollisionEnd(
            step=t.step,
            sim_time_ns=t.sim_time_ns,
            robot=robot,
            body1=self._bodies[t.body1],
            body2=self._bodies[t.body2],
            geom1=self._geoms[t.geom1],
            geom2=self._geoms[t.geom2],
            position=t.position,
            normal=t.normal,
            penetration=t.penetration,
            normal_force=t.normal_force,
            begin_step=t.begin_step,
            end_step=t.end_step,
            duration_ns=t.duration_ns,
            at_finish=t.at_finish,
            support=support,
        )

    def _near_miss(self, r: NearMissRecord, robot: str) -> NearMiss:
        return NearMiss(
            step=r.step,
            sim_time_ns=r.sim_time_ns,
            robot=robot,
            body1=self._bodies[r.body1],
            body2=self._bodies[r.body2],
            geom1=self._geoms[r.geom1],
            geom2=self._geoms[r.geom2],
            position=r.position,
            normal=r.normal,
            distance=r.distance,
            closest_step=r.closest_step,
            begin_step=r.begin_step,
            end_step=r.end_step,
            at_finish=r.at_finish,
        )
