"""``load_robot``: a robot description (URDF, SDF, MJCF or the bundled demo) into MuJoCo.

URDF goes through MuJoCo's own URDF importer (mesh URIs resolved and converted first, a
``<mujoco><compiler fusestatic="false" .../>`` element so every link stays a named body), then
one actuator per controllable joint, SRDF collision exclusions, the scene, compile.

Every file a model uses (meshes of any format, MJCF textures, height fields, skins, the
scene's) enters the spec as an in-memory asset named by its content
(:mod:`harness.models.files.assets`): the compiled model is the same byte for byte whichever folder
the project, the venv, the robot package or the mesh cache live in.

The steps live in their own modules: reading a source into a spec
(:mod:`harness.models.build.robot`), compiling and MuJoCo's messages
(:mod:`harness.models.build.compiler`), control modes and actuators
(:mod:`harness.models.build.actuators`), the world (:mod:`harness.models.world.build`) and its
keyframes (:mod:`harness.models.world.keyframes`); the bundled files in
:mod:`harness.models.bundled`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from harness.models.build.compiler import compile_spec, spec_from_file
from harness.models.build.decompose import MeshCollision
from harness.models.build.robot import describe_mjcf, model_kind, sdf_api, source_path
from harness.models.bundled import DEMO_URDF, SCENES
from harness.models.description import ControlMode, Pose, RobotModel
from harness.models.files.resolve import PackageMap
from harness.models.files.xmlsafe import read_xml_file
from harness.models.urdf.lenient import lenient_urdf
from harness.models.urdf.source import describe_urdf, read_urdf_source
from harness.models.world.build import load_world
from harness.models.world.records import (
    BaseKind,
    LoadedWorld,
    PoseLike,
    RobotSpec,
    SelfCollision,
    SelfCollisionReport,
)
from harness.models.xacro.expand import RobotArgs

__all__ = [
    "DEMO_URDF",
    "SCENES",
    "LoadedRobot",
    "LoadedWorld",
    "load_description",
    "load_robot",
    "load_world",
]


@dataclass(frozen=True)
class LoadedRobot:
    """A robot compiled into MuJoCo, with its description and everything needed to record it.

    ``control`` holds every controllable joint's mode; ``actuated`` the joint driven by each
    actuator index (actuators are named after their joint); ``kinematic`` the joints the
    simulation writes directly. ``mjcf`` is the compiled model saved as MJCF (MuJoCo writes
    6 significant digits: for humans and viewers); ``mjb`` the exact binary model
    (``mj_saveModel``), the one to replay from. ``sources`` maps ``"<role>/<file name>"``
    (roles: model, srdf, scene) to the file bytes; ``sha256`` is of ``mjcf``; ``repairs``
    lists every mass/inertia change made by ``repair_inertia``; ``notes`` what a lenient load
    recovered and how the robot was placed; ``self_collision`` the policy and the ignored link
    pairs; ``base`` fixed or floating; ``placement`` where the model frame is in the world
    (the ``pose`` asked for, lifted out of the floor if need be). ``spec`` carries the mesh and
    texture files in ``spec.assets`` (content-named): it compiles without the files.
    """

    name: str
    description: RobotModel
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    control: Mapping[str, ControlMode]
    actuated: tuple[str, ...]
    kinematic: tuple[str, ...]
    mjcf: str
    mjb: bytes
    sources: Mapping[str, bytes]
    sha256: str
    repairs: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    self_collision: SelfCollisionReport | None = None
    base: BaseKind = "fixed"
    placement: Pose = field(default_factory=Pose)
    visuals: bool = False
    """Whether visual geoms were kept (``load_robot(visuals=True)``)."""
    mesh_collision: str = "decompose"


def load_description(
    source: str | Path,
    *,
    robot_args: RobotArgs | None = None,
    packages: PackageMap | None = None,
    strict: bool = False,
) -> RobotModel:
    """The :class:`RobotModel` of ``source`` ("demo", .urdf, .xacro with ``robot_args``,
    ``package://``, .sdf/.world, MJCF) without building the MuJoCo model for URDF and SDF
    (MJCF is compiled to read it). ``strict``: as for :func:`load_robot`."""
    path = source_path(source, packages)
    kind = model_kind(path)
    if kind == "urdf":
        urdf = read_urdf_source(
            path, robot_args=robot_args, packages=packages, reference=str(source), strict=strict
        )
        lenient_urdf(urdf.root, str(path), strict=strict)
        return describe_urdf(urdf.root, str(path), urdf.origin)
    if kind == "sdf":
        read_sdf, _ = sdf_api()
        return read_sdf(path, strict=strict)
    read_xml_file(path)  # safety and well-formedness before MuJoCo's parser sees it
    spec = spec_from_file(path)
    return describe_mjcf(compile_spec(spec, str(path)), path)


def load_robot(
    source: str | Path = "demo",
    *,
    control: ControlMode | str | Mapping[str, ControlMode | str] = ControlMode.POSITION,
    scene: str | Path | None = None,
    packages: PackageMap | None = None,
    srdf: str | Path | None = None,
    visuals: bool = False,
    repair_inertia: bool = True,
    gains: Mapping[str, float] | None = None,
    cache_dir: str | Path | None = None,
    pose: PoseLike = None,
    initial_positions: Mapping[str, float] | None = None,
    robot_args: RobotArgs | None = None,
    strict: bool = False,
    self_collision: SelfCollision | None = None,
    base: BaseKind | None = None,
    mesh_collision: MeshCollision = "decompose",
) -> LoadedRobot:
    """Load ``source`` into MuJoCo with one actuator per controllable joint.

    ``source``: ``"demo"`` (default scene ``"table"``), or a .urdf, .sdf/.world or MJCF
    (.xml/.mjcf, taken as is: its own actuators are kept, others are added only when it has
    none, and it gets a scene only when one is asked for). ``control``: one mode for every
    controllable joint or a mapping joint -> mode (unlisted joints: ``"position"``).
    ``scene``: None (a floor), ``"floor"``, ``"empty"``, ``"table"`` or an MJCF world file.
    ``packages``: package name -> folder for ``package://``. ``srdf``: its
    ``<disable_collisions>`` become body-pair excludes. ``visuals``: keep visual geoms
    (non-colliding). ``repair_inertia`` (default): bound masses/inertias and balance
    inertias, reporting every changed link in ``repairs`` and as a :class:`ModelWarning`.
    ``strict``: refuse what a lenient load would recover or repair (bad inertias, a wrong XML
    declaration, trailing content, equal joint limits, ...). ``self_collision``: ``"auto"``,
    ``"off"``, ``"on"`` or ``"srdf"`` (see :mod:`harness.models.build.selfcollision`). ``base``:
    ``"fixed"`` or ``"floating"`` (see :mod:`harness.models.world.placement`). ``gains``: joint ->
    kp (position) or kv (velocity) overriding the defaults. ``cache_dir``: converted-mesh
    cache folder. ``mesh_collision``: ``"decompose"`` or ``"hull"`` (see
    :mod:`harness.models.build.decompose`).
    ``pose``: where the robot's base (model frame) is in the world (see
    :data:`harness.models.world.records.PoseLike`). ``initial_positions``: joint -> position
    overriding the ``home`` keyframe (created if the robot has none). ``robot_args``: the
    arguments of a xacro robot (name -> value, see :mod:`harness.models.xacro.expand`); ``source``
    may also be ``package://pkg/path`` (found like a mesh's package).

    A URDF's ``<harness>`` element adds keyframes and joint armature (see
    :func:`harness.models.urdf.reader.harness_extension`): the model depends on file contents only,
    never on where the file is. Position servos are critically damped (servo kv plus joint
    damping) for the inertia each joint sees with the others held, at the ``home`` keyframe;
    their joint gets the drive's torque-speed limit, effort / velocity, as extra damping, so a
    saturated servo moves at about its velocity limit and stops at its target.

    This is :func:`load_world` with one robot in the empty namespace: names stay unprefixed.
    """
    robot = RobotSpec(
        source,
        namespace="",
        pose=pose,
        control=control,
        gains=gains,
        packages=packages,
        srdf=srdf,
        visuals=visuals,
        repair_inertia=repair_inertia,
        initial_positions=dict(initial_positions or {}),
        robot_args=dict(robot_args or {}),
        strict=strict,
        self_collision=self_collision,
        base=base,
    )
    world = load_world([robot], scene=scene, cache_dir=cache_dir, mesh_collision=mesh_collision)
    view = world.robots[0]
    return LoadedRobot(
        name=view.description.name,
        description=view.description,
        spec=world.spec,
        model=world.model,
        control=view.control,
        actuated=view.actuated,
        kinematic=view.kinematic,
        mjcf=world.mjcf,
        mjb=world.mjb,
        sources=world.sources,
        sha256=world.sha256,
        repairs=view.repairs,
        notes=view.notes,
        self_collision=view.self_collision,
        visuals=visuals,
        base=view.base,
        placement=view.placement,
        mesh_collision=world.mesh_collision,
    )
