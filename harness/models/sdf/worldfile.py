"""SDFormat worlds as the map: a ``<world>`` file (1.4-1.11) becomes a MuJoCo scene spec.

Every model of the world (written in place or brought by ``<include>`` through the same
``model://`` search path as the SDF reader) is built as :func:`harness.models.sdf.build_spec`
builds a robot and attached at its ``<pose>`` with the prefix ``"<model>::"``, so its bodies,
joints and geoms are named ``model::link`` (``model::link/collision``), as Gazebo scopes them.
A static model is welded to the world; a model that is not static gets a free joint
(``model::link::__free__``) and can be pushed. ``<physics><max_step_size>`` becomes the
timestep and ``<gravity>`` the gravity (MuJoCo's defaults when absent); a collision's
``<surface><friction><ode><mu>`` its sliding friction. Lights, the sky, the scene's
ambient, plugins and actors carry no physics: only a world loaded with its visuals (for a
camera) has its visual geoms, their materials (:mod:`harness.models.sdf.materials`) and its
lights and ambient light (:mod:`harness.models.sdf.lights`). A ground plane is whatever
the world writes (usually ``model://ground_plane``: a bundled copy is on the search path
last, as are ``sun`` and Gazebo's other stock names the harness ships).

:func:`world_sources` lists every file a world reads (the world, each included model file,
each mesh) as recording sources ``"scene/..."``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType

import mujoco
from lxml import etree

from harness.models.bundled import DATA
from harness.models.description import ModelFrame, RobotModel
from harness.models.errors import ModelStructureError
from harness.models.files.xmlsafe import read_xml_file
from harness.models.sdf.build import build_spec
from harness.models.sdf.convert import PlacedModel, read_sdf_world, sdf_world
from harness.models.sdf.document import Entity, load_document
from harness.models.sdf.lights import apply_lighting, world_lighting

__all__ = [
    "BUNDLED_MODELS",
    "WORLD_SUFFIXES",
    "WorldScene",
    "is_sdf_world",
    "load_world_file",
    "world_description",
    "world_timestep",
]

BUNDLED_MODELS = DATA / "gazebo_models"
"""Stock Gazebo models the harness ships (``ground_plane``): searched after the user's paths."""
WORLD_SUFFIXES = (".sdf", ".world")


@dataclass(frozen=True)
class WorldScene:
    """A loaded SDF world: ``spec`` (no robot yet), its ``models`` as placed in the world,
    ``timestep`` and ``gravity`` as the world sets them (None: not set), and ``sources``:
    every file read, ``"scene/<name>"`` for the world, ``"scene/<model>/<path>"`` for the
    files of a Gazebo model folder (``"scene/fuel/<host>/<owner>/models/<name>/<version>/..."``
    for a Fuel cache's), laid out so that a rebuild resolves ``model://`` and Fuel URIs from
    the recording alone, and ``"scene/include/<i>/<name>"`` for the others."""

    name: str
    spec: mujoco.MjSpec
    models: tuple[PlacedModel, ...]
    timestep: float | None
    gravity: tuple[float, float, float] | None
    sources: Mapping[str, bytes]


def is_sdf_world(path: Path) -> bool:
    """True when ``path`` is an SDFormat file whose top element is a ``<world>``."""
    if path.suffix.lower() not in WORLD_SUFFIXES or not path.is_file():
        return False
    root, _ = read_xml_file(path)
    return any(isinstance(c.tag, str) and c.tag == "world" for c in root)


def world_timestep(path: Path) -> float:
    """The SDF world's ``<physics><max_step_size>`` (MuJoCo's default 0.002 when absent),
    read without loading its models."""
    root, _ = read_xml_file(path)
    world = root.find("world")
    if world is None:
        raise ModelStructureError(f"{path}: not an SDF world (no <world> element)")
    timestep, _ = _physics(world, str(path))
    return timestep if timestep is not None else float(mujoco.MjOption().timestep)


def _float_child(element: etree._Element, path: str, where: str) -> float | None:
    found = element.find(path)
    if found is None or not (found.text or "").strip():
        return None
    try:
        value = float((found.text or "").strip())
    except ValueError:
        raise ModelStructureError(
            f"{where}: line {found.sourceline}: <{found.tag}> {found.text!r} is not a number"
        ) from None
    if not math.isfinite(value):
        raise ModelStructureError(f"{where}: line {found.sourceline}: <{found.tag}> not finite")
    return value


def _physics(world: etree._Element, where: str) -> tuple[float | None, tuple[float, ...] | None]:
    timestep = None
    physics = world.find("physics")
    if physics is not None:
        timestep = _float_child(physics, "max_step_size", where)
        if timestep is not None and timestep <= 0:
            raise ModelStructureError(f"{where}: <physics><max_step_size> must be positive")
    gravity_el = world.find("gravity")
    if gravity_el is None and physics is not None:  # SDFormat 1.4 keeps it in <physics>
        gravity_el = physics.find("gravity")
    gravity = None
    if gravity_el is not None:
        try:
            gravity = tuple(float(v) for v in (gravity_el.text or "").split())
        except ValueError:
            gravity = ()
        if len(gravity) != 3 or not all(math.isfinite(g) for g in gravity):
            raise ModelStructureError(
                f"{where}: line {gravity_el.sourceline}: <gravity> needs 3 numbers"
            )
    return timestep, gravity


def _frictions(entity: Entity, prefix: str) -> dict[str, float]:
    """MuJoCo geom name -> ``<surface><friction><ode><mu>`` for the collisions of the links
    below ``entity`` (a model)."""
    found: dict[str, float] = {}
    for link in entity.walk():
        if link.kind != "link":
            continue
        name = link.path.removeprefix(prefix)
        for shape in link.collisions:
            geometry = shape.element.getparent()
            collision = geometry.getparent() if geometry is not None else None
            element = collision.find("surface/friction/ode/mu") if collision is not None else None
            if element is None:
                continue
            try:
                value = float((element.text or "").strip())
            except ValueError:
                raise ModelStructureError(
                    f"{link.source}: line {element.sourceline}: <mu> {element.text!r} is not a "
                    "number"
                ) from None
            if math.isfinite(value) and value >= 0:
                found[f"{name}/{shape.name}"] = value
    return found


def world_sources(
    path: Path, entities: Sequence[Entity], meshes: Sequence[str]
) -> dict[str, bytes]:
    """Every file of a world as recording sources (see :class:`WorldScene`)."""
    sources = {f"scene/{path.name}": path.read_bytes()}
    seen = {path.resolve()}
    files = [e.source for e in entities] + [Path(m) for m in meshes]
    placed: dict[str, Path] = {}  # layout name -> the model folder it stands for
    for file in files:
        resolved = file.resolve()
        if resolved in seen or not resolved.is_file():
            continue
        seen.add(resolved)
        laid = _model_layouts(resolved, placed)
        if not laid:
            sources[f"scene/include/{len(seen) - 1}/{resolved.name}"] = resolved.read_bytes()
            continue
        data = resolved.read_bytes()  # under each model folder holding it (links dedupe)
        for folder, name in laid:
            sources[f"scene/{name}/{resolved.relative_to(folder).as_posix()}"] = data
            config = folder / "model.config"
            if config.is_file() and f"scene/{name}/model.config" not in sources:
                sources[f"scene/{name}/model.config"] = config.read_bytes()
    return sources


def _model_layouts(file: Path, placed: dict[str, Path]) -> list[tuple[Path, str]]:
    """Where a file of Gazebo model folders goes in the recording, so that a rebuild
    resolves the world's ``model://`` and Fuel references from the recording alone: each
    model folder above ``file`` (one with a ``model.config``: ``model://turtlebot3_house/
    mailbox/meshes/mailbox.dae`` and ``model://mailbox/meshes/mailbox.dae`` name one file)
    with its layout name, ``<model name>`` beside the world (found from the world's folder as
    ``model://`` is) or ``fuel/<host>/<owner>/models/<name>/<version>`` for a Fuel cache's
    copy (the rebuild's Fuel cache, :func:`harness.models.files.fuel.fuel_cache_roots`). None for
    the harness's own stock models (found in the harness again), a file in no model folder,
    and a second folder of a name already laid out."""
    if any(file.is_relative_to(own) for own in (DATA, DATA.resolve())):
        return []
    found = []
    for folder in file.parents:
        if not (folder / "model.config").is_file():
            continue
        parts = folder.parts
        if folder.name.isdigit() and len(parts) >= 6 and parts[-3] == "models":
            name = "/".join(("fuel", parts[-5], parts[-4], "models", parts[-2], parts[-1]))
        elif folder.name in ("fuel", "include"):
            continue
        else:
            name = folder.name
        if placed.setdefault(name, folder) == folder:
            found.append((folder, name))
    return found


def load_world_file(
    path: str | Path,
    *,
    search_paths: Sequence[str | Path] | None = None,
    cache_dir: str | Path | None = None,
    visuals: bool = False,
) -> WorldScene:
    """Read the SDF world at ``path`` into a :class:`WorldScene` (see the module docstring).
    ``search_paths``: folders searched first for ``model://`` includes and meshes;
    ``visuals``: build the visual geoms with their materials, and the lights (what a camera
    draws), the collision geoms then in a group cameras do not draw."""
    path = Path(path)
    paths = [*(search_paths or ()), BUNDLED_MODELS]
    document = load_document(path, search_paths=paths, strict=False)
    if document.root.kind != "world":
        raise ModelStructureError(f"{path}: not an SDF world (its top element is a <model>)")
    world = sdf_world(document, search_paths=paths)
    timestep, gravity = _physics(document.root.element, str(path))
    spec = mujoco.MjSpec()
    spec.modelname = world.name or path.stem
    spec.compiler.degree = False
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    if timestep is not None:
        spec.option.timestep = timestep
    if gravity is not None:
        spec.option.gravity = list(gravity)
    entities = {e.name: e for e in document.root.of_kind("model")}
    meshes: list[str] = []
    drawn: list[str] = []
    assets: dict[str, bytes] = {}
    for placed in world.models:
        model_spec = build_spec(placed.model, visuals=visuals, cache_dir=cache_dir)
        entity = entities[placed.name]
        for geom_name, mu in _frictions(entity, entity.path + "::").items():
            geom = model_spec.geom(geom_name)
            if geom is not None:
                geom.friction = [mu, geom.friction[1], geom.friction[2]]
        assets.update(model_spec.assets)
        meshes += [
            s.geometry.mesh_path or ""
            for link in placed.model.links
            for s in link.collisions
            if s.geometry.kind == "mesh"
        ]
        if visuals:  # what the visuals read: their meshes and textures
            shapes = [s for link in placed.model.links for s in link.visuals]
            drawn += [s.geometry.mesh_path or "" for s in shapes if s.geometry.kind == "mesh"]
            drawn += [s.appearance.texture for s in shapes if s.appearance and s.appearance.texture]
        frame = spec.worldbody.add_frame(pos=list(placed.pose.xyz), quat=list(placed.pose.quat))
        spec.attach(model_spec, prefix=f"{placed.name}::", frame=frame)
    if assets:
        spec.assets = {**spec.assets, **assets}
    if visuals:
        version = document.root.version
        apply_lighting(spec, world_lighting(document.root.element, path, version, paths))
    every = [e for e in document.root.walk() if e.kind == "model"]
    beside, elsewhere = _beside_world(path, drawn, meshes)
    return WorldScene(
        name=str(spec.modelname),
        spec=spec,
        models=world.models,
        timestep=timestep,
        gravity=None if gravity is None else (gravity[0], gravity[1], gravity[2]),
        sources=MappingProxyType({**world_sources(path, every, meshes + elsewhere), **beside}),
    )


def _beside_world(
    path: Path, drawn: Sequence[str], meshes: Sequence[str]
) -> tuple[dict[str, bytes], list[str]]:
    """The files only visuals read (meshes, textures) in the world's folder, as sources
    ``"scene/<path from that folder>"``, where a rebuild finds them by the same relative
    reference; and the other files (for :func:`world_sources`)."""
    folder = path.resolve().parent
    colliding = {Path(m).resolve() for m in meshes if m}
    beside: dict[str, bytes] = {}
    elsewhere: list[str] = []
    for name in drawn:
        file = Path(name).resolve() if name else None
        if file is None or not file.is_file() or file in colliding:
            continue
        if file.is_relative_to(folder):
            beside[f"scene/{file.relative_to(folder).as_posix()}"] = file.read_bytes()
        else:
            elsewhere.append(name)
    return beside, elsewhere


def _scoped(prefix: str, name: str) -> str:
    return name if name == "world" else prefix + name


def world_description(
    path: str | Path, *, search_paths: Sequence[str | Path] | None = None
) -> RobotModel:
    """Every model of the SDF world at ``path`` as one :class:`RobotModel` in the world frame,
    names scoped ``model::link`` (for ``harness inspect-model``)."""
    path = Path(path)
    world = read_sdf_world(path, search_paths=[*(search_paths or ()), BUNDLED_MODELS])
    links, joints, frames = [], [], list(world.frames)
    for placed in world.models:
        prefix, place = f"{placed.name}::", placed.pose
        model = placed.model
        for link in model.links:
            inertial = link.inertial
            links.append(
                replace(
                    link,
                    name=prefix + link.name,
                    pose=place * link.pose,
                    inertial=None
                    if inertial is None
                    else replace(inertial, pose=place * inertial.pose),
                    collisions=tuple(replace(c, pose=place * c.pose) for c in link.collisions),
                    visuals=tuple(replace(v, pose=place * v.pose) for v in link.visuals),
                )
            )
        for joint in model.joints:
            joints.append(
                replace(
                    joint,
                    name=prefix + joint.name,
                    parent=_scoped(prefix, joint.parent),
                    child=_scoped(prefix, joint.child),
                    pose=place * joint.pose,
                    axis=place.rotate(joint.axis),
                    mimic=None
                    if joint.mimic is None
                    else replace(joint.mimic, joint=prefix + joint.mimic.joint),
                )
            )
        frames.append(ModelFrame(f"{placed.name}::__model__", "world", place))
        for frame in model.frames:
            frames.append(
                replace(
                    frame,
                    name=prefix + frame.name,
                    attached_to=_scoped(prefix, frame.attached_to),
                    pose=place * frame.pose,
                )
            )
    return RobotModel(
        world.name or path.stem,
        tuple(links),
        tuple(joints),
        tuple(frames),
        source=str(path),
        format="sdf",
    )
