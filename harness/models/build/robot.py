"""A robot being built (:class:`RobotBuild`): its source located and read (URDF, xacro, SDF
or MJCF by suffix), its MuJoCo spec built, its names not yet prefixed into a world; and
where a joint's positions and velocities lie in ``qpos`` and ``qvel``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.models.build import setup
from harness.models.build.compiler import compile_spec, spec_from_file, spec_from_string
from harness.models.build.drive_plugins import plugin_wheels
from harness.models.build.inertia import settle_edge_inertias
from harness.models.build.passive import declared_actuated
from harness.models.build.selfcollision import declared_link_self_collide, declared_self_collide
from harness.models.bundled import DEMO_URDF
from harness.models.description import ControlMode, RobotModel
from harness.models.errors import ModelStructureError
from harness.models.files.assets import embed_files
from harness.models.files.limits import check_description, check_urdf_counts
from harness.models.files.resolve import PackageMap
from harness.models.files.xmlsafe import read_xml_file
from harness.models.urdf import surfaces
from harness.models.urdf.lenient import lenient_urdf
from harness.models.urdf.reader import harness_extension, mujoco_urdf_xml
from harness.models.urdf.ros2_control import warn_replaced_hardware
from harness.models.urdf.source import describe_urdf, initial_keyframes, locate, read_urdf_source
from harness.models.world.records import BaseKind, RobotSpec, SelfCollisionReport
from harness.models.xacro.expand import is_xacro

__all__ = [
    "MJCF_SUFFIXES",
    "SDF_SUFFIXES",
    "URDF_SUFFIXES",
    "RobotBuild",
    "describe_mjcf",
    "dof_span",
    "model_kind",
    "qpos_span",
    "sdf_api",
    "source_path",
]

URDF_SUFFIXES = (".urdf",)
MJCF_SUFFIXES = (".xml", ".mjcf")
SDF_SUFFIXES = (".sdf", ".world")


def model_kind(path: Path) -> str:
    """``"urdf"`` (also xacro), ``"mjcf"`` or ``"sdf"``, by the file's suffix."""
    suffix = path.suffix.lower()
    if suffix in URDF_SUFFIXES or is_xacro(path):
        return "urdf"
    if suffix in MJCF_SUFFIXES:
        return "mjcf"
    if suffix in SDF_SUFFIXES:
        return "sdf"
    raise ModelStructureError(
        f"{path}: unknown model format {path.suffix!r} (expected .urdf, .xacro, .sdf, .world, "
        ".xml, .mjcf)"
    )


def source_path(source: str | Path, packages: PackageMap | None = None) -> Path:
    """The file ``source`` names: ``"demo"``, a path or ``package://``."""
    if str(source) == "demo":
        return DEMO_URDF
    return locate(source, packages)


def sdf_api() -> tuple[Callable[..., RobotModel], Callable[..., mujoco.MjSpec]]:
    """The SDF reader's ``read_sdf`` and ``build_spec``, imported only when an SDF is loaded."""
    try:
        sdf: object = importlib.import_module("harness.models.sdf")
    except ImportError:
        sdf = None
    read = getattr(sdf, "read_sdf", None)
    build = getattr(sdf, "build_spec", None)
    if read is None or build is None:
        raise ModelStructureError("SDF is not available yet (harness.models.sdf is missing)")
    return read, build


def describe_mjcf(model: mujoco.MjModel, path: Path) -> RobotModel:
    """The :class:`RobotModel` of a compiled MJCF model read from ``path``."""
    from harness.models.mjcf.describe import description_from_model

    return description_from_model(model, path.stem, str(path))


class RobotBuild:
    """A robot being assembled: its source read, its spec built, its names not yet in a world
    (what :class:`harness.models.build.setup.RobotInBuild` reads and writes)."""

    def __init__(self, index: int, robot: RobotSpec, cache_dir: str | Path | None) -> None:
        self.index = index
        self.request = robot
        self.namespace = ""
        self.prefix = ""
        self.path = source_path(robot.source, robot.packages)
        self.source = str(self.path)
        self.kind = model_kind(self.path)
        self.model_bytes = b""
        self.extra_sources: Mapping[str, bytes] = {}  # a xacro robot's files read and meshes
        self.existing_actuators = False
        # key name -> joint -> position, from a URDF's <harness> element
        self.extension_keys: Mapping[str, Mapping[str, float]] = {}
        self.spec_keys: tuple[str, ...] = ()  # keys the robot's own spec brings (MJCF)
        self.source_repairs: tuple[str, ...] = ()
        self.repaired_inertias: Mapping[str, tuple[float, ...]] = {}
        self.modes: dict[str, ControlMode] = {}
        self.actuated: tuple[str, ...] = ()
        self.srdf_bytes: bytes | None = None
        self.srdf_pairs: tuple[tuple[str, str], ...] = ()
        self.repairs_made: tuple[str, ...] = ()
        self.notes: list[str] = []
        self.declared_self_collide: bool | None = None
        self.link_self_collide: dict[str, bool] = {}
        self.frame: Any = None
        self.base: BaseKind = "fixed"
        self.self_collision: SelfCollisionReport | None = None
        self.repair = robot.repair_inertia and not robot.strict
        self.plugin_wheels: tuple[str, ...] = ()  # joints a file's drive plugin drives
        self.declared_actuated: frozenset[str] = frozenset()  # see harness.models.build.passive
        setup.check_options(robot, self.source)
        path = self.path
        if self.kind == "urdf":
            urdf = read_urdf_source(
                path, robot_args=robot.robot_args, packages=robot.packages,
                reference=str(robot.source), strict=robot.strict,
            )  # fmt: skip
            root, self.model_bytes, self.extra_sources = urdf.root, urdf.data, urdf.extra
            self.path = urdf.path  # a xacro robot is recorded as its expanded URDF
            check_urdf_counts(root, self.source)
            notes = [*urdf.notes, *lenient_urdf(root, self.source, strict=robot.strict)]
            self.notes.extend(str(n) for n in notes)
            self.declared_self_collide = declared_self_collide(root)
            self.link_self_collide = declared_link_self_collide(root)
            self.description = describe_urdf(root, self.source, urdf.origin)
            warn_replaced_hardware(self.description.ros2_control, self.source)
            check_description(self.description, self.source)  # before MuJoCo reads the tree
            prepared = mujoco_urdf_xml(
                root,
                path,
                packages=robot.packages,
                visuals=robot.visuals,
                repair_inertia=self.repair,
                cache_dir=cache_dir,
            )
            self.source_repairs, self.repaired_inertias = prepared.repairs, prepared.inertias
            self.spec = spec_from_string(prepared.xml, self.source, prepared.assets)
            settle_edge_inertias(self.spec)  # a thin disc: MuJoCo's rounding must not refuse it
            extension = harness_extension(root, self.description)
            self.extension_keys = initial_keyframes(extension.keyframes, self.description)
            for joint_name, armature in extension.armature.items():
                self.spec.joint(joint_name).armature = armature
            surfaces.apply_frictions(
                self.spec, surfaces.gazebo_frictions(root, self.source), self.source
            )
            self.plugin_wheels = plugin_wheels(root)
            self.declared_actuated = declared_actuated(root, self.description, self.plugin_wheels)
            if robot.base == "floating":
                if any(link.name == "world" for link in self.description.links):
                    raise ModelStructureError(
                        f"{self.source}: base='floating' but the URDF fixes the robot to a "
                        "link named 'world'"
                    )
                setup.make_floating(self.spec, self.source)
                self.base = "floating"
        elif self.kind == "sdf":
            read_sdf, build_spec = sdf_api()
            self.model_bytes = path.read_bytes()
            self.description = read_sdf(path, strict=robot.strict)
            check_description(self.description, self.source)
            self.spec = build_spec(self.description, cache_dir=cache_dir)
            sdf_root = read_xml_file(path)[0]
            self.plugin_wheels = plugin_wheels(sdf_root)
            self.declared_self_collide = declared_self_collide(sdf_root)
            self.link_self_collide = declared_link_self_collide(sdf_root)
            self.base = setup.sdf_base(self.spec, robot.base)
        else:
            _, self.model_bytes = read_xml_file(path)
            self.spec = spec_from_file(path)
            embed_files(self.spec, source=self.source, cache_dir=cache_dir)
            self.description = describe_mjcf(compile_spec(self.spec.copy(), self.source), path)
            self.existing_actuators = len(self.spec.actuators) > 0
        self.spec_keys = tuple(key.name for key in self.spec.keys)

    def set_namespace(self, namespace: str) -> None:
        self.namespace = namespace
        self.prefix = f"{namespace}/" if namespace else ""

    def where(self, several: bool) -> str:
        return f"robots[{self.index}] ({self.source})" if several else self.source

    def joint_ids(self, model: mujoco.MjModel) -> list[int]:
        """This robot's MuJoCo joints, in model order."""
        names = {self.prefix + j.name for j in self.description.joints}
        return [j for j in range(model.njnt) if model.joint(j).name in names]

    def own_key(self, model: mujoco.MjModel, key: str) -> int:
        """The id of this robot's own attached key ``key`` in ``model`` (-1 if none)."""
        if key not in self.spec_keys:
            return -1
        return int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, self.prefix + key))

    def key_values(
        self, model: mujoco.MjModel, key: str, qpos: npt.NDArray[np.float64]
    ) -> tuple[int, bool]:
        """Write this robot's positions of keyframe ``key`` into ``qpos`` (its ``home`` when
        it has no such key); returns the own attached key used (-1: none) and whether any
        source keyframe was found."""
        for name in (key, "home"):
            if name in self.extension_keys:
                for joint, value in self.extension_keys[name].items():
                    qpos[model.jnt_qposadr[model.joint(self.prefix + joint).id]] = value
                return -1, True
            own = self.own_key(model, name)
            if own >= 0:
                for j in self.joint_ids(model):
                    start, width = qpos_span(model, j)
                    qpos[start : start + width] = model.key_qpos[own][start : start + width]
                return own, True
        return -1, False


def qpos_span(model: mujoco.MjModel, joint: int) -> tuple[int, int]:
    """The first ``qpos`` index of ``joint`` and how many it has."""
    start = int(model.jnt_qposadr[joint])
    end = int(model.jnt_qposadr[joint + 1]) if joint + 1 < model.njnt else int(model.nq)
    return start, end - start


def dof_span(model: mujoco.MjModel, joint: int) -> tuple[int, int]:
    """The first dof (``qvel`` index) of ``joint`` and how many it has."""
    start = int(model.jnt_dofadr[joint])
    end = int(model.jnt_dofadr[joint + 1]) if joint + 1 < model.njnt else int(model.nv)
    return start, end - start
