"""Which pairs of a robot's own links collide: the self-collision policy.

Real robot descriptions are drawn for looks and for motion planning, not for contact physics:
collision meshes of neighbouring links overlap, and links that never touch on the real robot
intersect in the file. Gazebo lets no two links of a model collide unless the model asks for
it (``<self_collide>``); MoveIt computes the pairs to ignore and writes them to the SRDF. The
policies:

- ``"auto"`` (the default), MoveIt's setup assistant: ignore adjacent links (joined by one
  joint, or welded together), pairs in contact at the initial configuration (``"default"``),
  and pairs in contact in at least :data:`ALWAYS_FRACTION` of :data:`SAMPLES` random
  configurations within the joint limits (``"always"``), drawn with a fixed seed;
- ``"off"``: no two links of the robot collide (Gazebo's default);
- ``"on"``: every pair collides except adjacent links (Gazebo's ``self_collide`` true);
- ``"srdf"``: the SRDF's ``<disable_collisions>`` pairs (and adjacent links).

A URDF ``<gazebo><self_collide>`` or an SDF ``<model><self_collide>`` chooses ``"on"`` or
``"off"`` when no policy is passed. A link's own ``self_collide`` (URDF ``<gazebo
reference="LINK">``, SDF ``<link><self_collide>``) is honoured as SDFormat defines it: two
links collide when either has ``self_collide`` true (a link without one takes the model's),
links joined by a joint never do. So a link marked true collides with the robot's other
links even under ``"off"``, except adjacent ones, SRDF-disabled ones and the pairs found in
contact at the initial configuration or in nearly every configuration (``"default"``,
``"always"``: in MuJoCo a mesh collides as convex shapes (its hull, or the pieces of
:mod:`harness.models.build.decompose`, in the link's body: the pairs and exclusions are the
links'), and such a pair would hold the robot still from the first step; they stay
reported); a pair whose links are both false, one by its own flag, is ignored
(``"link"``). A policy passed as an argument overrides the file,
these flags included.
Pairs are computed on the compiled model; results are
cached in memory by a hash of that model, the robot and the sampling settings. Pairs that are
not ignored keep colliding and are reported by the CollisionLogger like any other contact.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from types import MappingProxyType

import mujoco
import numpy as np
import numpy.typing as npt
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.models.world.records import IgnoredPair, SelfCollision

__all__ = [
    "ALWAYS_FRACTION",
    "GEOMETRIC",
    "SAMPLES",
    "SEED",
    "declared_link_self_collide",
    "declared_self_collide",
    "ignored_pairs",
    "link_self_collide",
]

SAMPLES = 200
"""Random configurations drawn by ``"auto"``."""
ALWAYS_FRACTION = 0.95
"""A pair in contact in at least this fraction of the samples is ignored as ``"always"``."""
SEED = 0
"""The sampling seed: the same model always gives the same pairs."""

_CACHE: dict[str, tuple[IgnoredPair, ...]] = {}
_CACHE_SIZE = 256


def declared_self_collide(root: etree._Element) -> bool | None:
    """The model-level ``self_collide`` of a URDF ``<robot>`` (``<gazebo>`` without a
    ``reference``) or an SDF ``<sdf>`` (its first ``<model>``); None when absent."""
    candidates = []
    if root.tag == "robot":
        candidates = [
            g.find("self_collide") for g in root.findall("gazebo") if not g.get("reference")
        ]
    elif root.tag == "sdf":
        model = root.find("model")
        if model is None:
            world = root.find("world")
            model = world.find("model") if world is not None else None
        if model is not None:
            candidates = [model.find("self_collide")]
    for element in candidates:
        if element is not None and element.text is not None:
            return element.text.strip().lower() in ("1", "true")
    return None


def _flag(element: etree._Element | None) -> bool | None:
    if element is None or element.text is None:
        return None
    return bool(element.text.strip().lower() in ("1", "true"))


GEOMETRIC = ("adjacent", "srdf", "default", "always")
"""Reasons a pair stays ignored when a link of it has ``self_collide`` true."""


def declared_link_self_collide(root: etree._Element) -> dict[str, bool]:
    """Each link's own ``self_collide``: a URDF ``<gazebo reference="LINK">`` block's, or an
    SDF ``<link>``'s (of the first model); links without one are left out."""
    flags: dict[str, bool] = {}
    if root.tag == "robot":
        for gazebo in root.findall("gazebo"):
            link, value = gazebo.get("reference"), _flag(gazebo.find("self_collide"))
            if link and value is not None:
                flags[link] = value
    elif root.tag == "sdf":
        model = root.find("model")
        if model is None:
            world = root.find("world")
            model = world.find("model") if world is not None else None
        for element in model.findall("link") if model is not None else ():
            value = _flag(element.find("self_collide"))
            if element.get("name") and value is not None:
                flags[str(element.get("name"))] = value
    return flags


def link_self_collide(
    model: mujoco.MjModel,
    robot_bodies: Mapping[str, int],
    pairs: Sequence[IgnoredPair],
    flags: Mapping[str, bool],
    model_flag: bool | None,
) -> list[IgnoredPair]:
    """``pairs`` (the policy's ignored pairs) with the links' own ``self_collide`` applied
    (see the module docstring): a pair with a link whose flag is true (its own, else
    ``model_flag``) is no longer ignored unless adjacent, disabled by the SRDF or in contact
    at the start or always (:data:`GEOMETRIC`); a pair whose links are both false, one of
    them by its own flag, is ignored as ``"link"``."""
    if not flags:
        return list(pairs)

    def flag(link: str) -> bool | None:
        return flags.get(link, model_flag)

    kept = [p for p in pairs if p.reason in GEOMETRIC or not (flag(p.link1) or flag(p.link2))]
    ignored = {frozenset((p.link1, p.link2)) for p in kept}
    has_geom = np.zeros(model.nbody, dtype=bool)
    has_geom[model.geom_bodyid[_colliding_geoms(model)]] = True
    links = [link for link, body in robot_bodies.items() if has_geom[body]]
    for i, a in enumerate(links):
        for b in links[i + 1 :]:
            if frozenset((a, b)) in ignored or (a not in flags and b not in flags):
                continue
            if flag(a) is False and flag(b) is False:
                kept.append(IgnoredPair(a, b, "link"))
    return kept


def _colliding_geoms(model: mujoco.MjModel) -> npt.NDArray[np.bool_]:
    mask: npt.NDArray[np.bool_] = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return mask


def _rigid_root(model: mujoco.MjModel, body: int, robot: set[int]) -> int:
    """The body's nearest ancestor-or-self that moves on its own (has a joint), or the
    robot's top body: bodies with the same root are welded together."""
    while model.body_jntnum[body] == 0 and int(model.body_parentid[body]) in robot:
        body = int(model.body_parentid[body])
    return body


def _adjacent(
    model: mujoco.MjModel, bodies: Sequence[int], robot: set[int]
) -> set[tuple[int, int]]:
    roots = {b: _rigid_root(model, b, robot) for b in bodies}
    pairs = set()
    for i, a in enumerate(bodies):
        for b in bodies[i + 1 :]:
            ra, rb = roots[a], roots[b]
            parent_a = _rigid_root(model, int(model.body_parentid[ra]), robot)
            parent_b = _rigid_root(model, int(model.body_parentid[rb]), robot)
            joined = (int(model.body_parentid[ra]) in robot and parent_a == rb) or (
                int(model.body_parentid[rb]) in robot and parent_b == ra
            )
            if ra == rb or joined:
                pairs.add((min(a, b), max(a, b)))
    return pairs


def _contact_pairs(
    model: mujoco.MjModel, data: mujoco.MjData, robot: set[int]
) -> set[tuple[int, int]]:
    ncon = int(data.ncon)
    if ncon == 0:
        return set()
    geoms = data.contact.geom[:ncon]
    dist = data.contact.dist[:ncon]
    b1 = model.geom_bodyid[geoms[:, 0]]
    b2 = model.geom_bodyid[geoms[:, 1]]
    pairs = set()
    for x, y, d in zip(b1.tolist(), b2.tolist(), dist.tolist(), strict=True):
        if x != y and x in robot and y in robot and d <= 0.0:
            pairs.add((min(x, y), max(x, y)))
    return pairs


_SLIDE_SPAN = 10.0
"""Metres either side of zero within which a slide is sampled."""


def _sampling_ranges(
    model: mujoco.MjModel, joints: Sequence[int]
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """qpos addresses and ranges of the robot's hinges and slides: their limits, or a full
    turn for an unlimited hinge (unlimited slides stay where they are)."""
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    addresses, lows, highs = [], [], []
    for j in joints:
        kind = int(model.jnt_type[j])
        if kind not in (hinge, slide):
            continue
        if model.jnt_limited[j]:
            low, high = (float(v) for v in model.jnt_range[j])
            # beyond a turn a hinge repeats itself; a slide is sampled within _SLIDE_SPAN
            # (and a range wider than a float can span cannot be sampled at all)
            bound = np.pi if kind == hinge else _SLIDE_SPAN
            low, high = max(low, -bound), min(high, bound)
            if low > high:  # a range wholly outside the window: held at its lower limit
                low, high = float(model.jnt_range[j][0]), float(model.jnt_range[j][0])
        elif kind == hinge:
            low, high = -np.pi, np.pi
        else:
            continue
        addresses.append(int(model.jnt_qposadr[j]))
        lows.append(low)
        highs.append(high)
    return (
        np.asarray(addresses, dtype=np.intp),
        np.asarray(lows, dtype=np.float64),
        np.asarray(highs, dtype=np.float64),
    )


def _cache_key(
    model: mujoco.MjModel, bodies: Sequence[int], qpos: npt.NDArray[np.float64], policy: str
) -> str:
    digest = hashlib.sha256()
    size = mujoco.mj_sizeModel(model)
    buffer = np.zeros(size, dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    digest.update(buffer.tobytes())
    digest.update(np.asarray(bodies, dtype=np.int64).tobytes())
    digest.update(np.asarray(qpos, dtype=np.float64).tobytes())
    digest.update(f"{policy}/{SAMPLES}/{ALWAYS_FRACTION}/{SEED}".encode())
    return digest.hexdigest()


def ignored_pairs(
    model: mujoco.MjModel,
    robot_bodies: Mapping[str, int],
    joints: Sequence[int],
    qpos: npt.NDArray[np.float64],
    policy: SelfCollision,
) -> tuple[IgnoredPair, ...]:
    """The link pairs of one robot to ignore under ``policy`` (``"srdf"`` adds only the
    adjacent pairs: the SRDF's own pairs are added by the caller).

    ``model``: the compiled world without the pairs excluded yet; ``robot_bodies``: link
    name -> body id of the robot; ``joints``: the robot's joint ids; ``qpos``: the world's
    initial configuration. Deterministic: a fixed seed, the same answer for the same model.
    """
    names = {body: link for link, body in robot_bodies.items()}
    robot = set(names)
    has_geom = np.zeros(model.nbody, dtype=bool)
    colliding = _colliding_geoms(model)
    has_geom[model.geom_bodyid[colliding]] = True
    bodies = sorted(b for b in robot if has_geom[b])
    key = _cache_key(model, bodies, qpos, policy)
    cached = _CACHE.get(key)
    if cached is not None:
        return cached

    reasons: dict[tuple[int, int], str] = {}
    for pair in sorted(_adjacent(model, bodies, robot)):
        reasons[pair] = "adjacent"
    if policy == "off":
        for i, a in enumerate(bodies):
            for b in bodies[i + 1 :]:
                reasons.setdefault((a, b), "off")
    elif policy == "auto":
        data = mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        for pair in sorted(_contact_pairs(model, data, robot)):
            reasons.setdefault(pair, "default")
        rng = np.random.default_rng(SEED)
        addresses, lows, highs = _sampling_ranges(model, joints)
        samples = rng.uniform(lows, highs, size=(SAMPLES, len(addresses)))
        counts: dict[tuple[int, int], int] = {}
        for sample in samples:
            data.qpos[:] = qpos
            data.qpos[addresses] = sample
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)
            for pair in _contact_pairs(model, data, robot):
                counts[pair] = counts.get(pair, 0) + 1
        for pair in sorted(counts):
            if counts[pair] >= ALWAYS_FRACTION * SAMPLES:
                reasons.setdefault(pair, "always")
    result = tuple(
        IgnoredPair(names[a], names[b], reason) for (a, b), reason in sorted(reasons.items())
    )
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = result
    return result


REASONS: Mapping[str, str] = MappingProxyType(
    {
        "adjacent": "joined by one joint or welded together",
        "default": "in contact at the initial configuration",
        "always": f"in contact in >= {ALWAYS_FRACTION:.0%} of {SAMPLES} random configurations",
        "srdf": "disabled by the SRDF",
        "off": "self-collision off",
        "link": "self_collide false on both links (the file's per-link setting)",
    }
)
"""What each reason of an :class:`IgnoredPair` means."""
