"""Robot descriptions: URDF (plain or xacro), SDF and MJCF into one `RobotModel` and a compiled
MuJoCo model.

One subpackage per concern; a newcomer reads them in this order:

- ``description.py``: :class:`RobotModel`, the one description every format becomes.
- ``files/``: reading files safely (references resolved, reads confined, safe XML, limits,
  Fuel cache, in-memory assets, mesh conversion).
- ``urdf/``, ``xacro/``, ``sdf/``, ``mjcf/``: one reader per format (SDF also reads worlds).
- ``build/``: a robot into MuJoCo (spec, compile, actuators and drives, passive joints,
  inertia and collision meshes, self-collision policy); ``load_robot``/``load_world``.
- ``world/``: several robots, objects and a map in one compiled world.
- ``check/``: ``harness check-model``.

Dependencies point down this list (a format reader never imports ``build/``); a module's old
flat path (``harness.models.compiler``) still imports, with a deprecation warning, for one
release."""

from harness._moved import alias_modules
from harness.models._cli import add_load_options, add_robot_arg_option, load_options, robot_args
from harness.models.build.compiler import spec_from_file
from harness.models.build.decompose import DECOMPOSITION_FOLDER, MeshCollision, check_mesh_collision
from harness.models.build.drive_plugins import drive_plugin_elements
from harness.models.build.load import (
    DEMO_URDF,
    SCENES,
    LoadedRobot,
    load_description,
    load_robot,
    load_world,
)
from harness.models.description import (
    CONTROL_MODE_INPUTS,
    CONTROL_MODES,
    ControlMode,
    Geometry,
    Inertial,
    Joint,
    JointLimits,
    Link,
    Mimic,
    ModelFrame,
    Pose,
    RobotModel,
    Shape,
)
from harness.models.errors import CompileError, ModelError, OutsideReferenceError, XacroError
from harness.models.files.confine import confined_to
from harness.models.files.limits import ModelLimitError, check_model_limits, check_spec
from harness.models.files.meshes import mesh_cache_dir
from harness.models.files.resolve import MODEL_PATH_VARIABLES, resolve_uri
from harness.models.files.xmlsafe import parse_xml, parse_xml_kept
from harness.models.mjcf.files import check_mjcf_files, generated_from
from harness.models.sdf.worldfile import is_sdf_world, load_world_file, world_timestep
from harness.models.urdf.ros2_control import HardwareReplacedWarning, Ros2Control
from harness.models.world.rebuild import WorldBuild
from harness.models.world.records import (
    OBJECT_SIZES,
    BaseKind,
    DuplicateNamespaceError,
    InvalidNamespaceError,
    JointAddress,
    LoadedRobotView,
    LoadedWorld,
    PoseLike,
    RobotSpec,
    SelfCollision,
    WorldObject,
    add_object,
    object_friction,
    set_object_values,
)
from harness.models.xacro.expand import UnusedRobotArgWarning, XacroOrigin, expand_xacro

__all__ = [
    "CONTROL_MODES",
    "CONTROL_MODE_INPUTS",
    "DECOMPOSITION_FOLDER",
    "DEMO_URDF",
    "MODEL_PATH_VARIABLES",
    "OBJECT_SIZES",
    "SCENES",
    "BaseKind",
    "CompileError",
    "ControlMode",
    "DuplicateNamespaceError",
    "Geometry",
    "HardwareReplacedWarning",
    "Inertial",
    "InvalidNamespaceError",
    "Joint",
    "JointAddress",
    "JointLimits",
    "Link",
    "LoadedRobot",
    "LoadedRobotView",
    "LoadedWorld",
    "MeshCollision",
    "Mimic",
    "ModelError",
    "ModelFrame",
    "ModelLimitError",
    "OutsideReferenceError",
    "Pose",
    "PoseLike",
    "RobotModel",
    "RobotSpec",
    "Ros2Control",
    "SelfCollision",
    "Shape",
    "UnusedRobotArgWarning",
    "WorldBuild",
    "WorldObject",
    "XacroError",
    "XacroOrigin",
    "add_load_options",
    "add_object",
    "add_robot_arg_option",
    "check_mesh_collision",
    "check_mjcf_files",
    "check_model_limits",
    "check_spec",
    "confined_to",
    "drive_plugin_elements",
    "expand_xacro",
    "generated_from",
    "is_sdf_world",
    "load_description",
    "load_options",
    "load_robot",
    "load_world",
    "load_world_file",
    "mesh_cache_dir",
    "object_friction",
    "parse_xml",
    "parse_xml_kept",
    "resolve_uri",
    "robot_args",
    "set_object_values",
    "spec_from_file",
    "world_timestep",
]


# Modules that moved into subpackages (issue 32): their old paths work for one release.
alias_modules(
    {
        "harness.models.resolve": "harness.models.files.resolve",
        "harness.models.confine": "harness.models.files.confine",
        "harness.models.xmlsafe": "harness.models.files.xmlsafe",
        "harness.models.limits": "harness.models.files.limits",
        "harness.models.assets": "harness.models.files.assets",
        "harness.models.meshes": "harness.models.files.meshes",
        "harness.models.urdf_source": "harness.models.urdf.source",
        "harness.models.lenient": "harness.models.urdf.lenient",
        "harness.models.surfaces": "harness.models.urdf.surfaces",
        "harness.models.ros2_control": "harness.models.urdf.ros2_control",
        "harness.models.xacro_eval": "harness.models.xacro.evaluate",
        "harness.models.xacro_meter": "harness.models.xacro.meter",
        "harness.models.mjcf_files": "harness.models.mjcf.files",
        "harness.models.worldfile": "harness.models.sdf.worldfile",
        "harness.models.fuel": "harness.models.files.fuel",
        "harness.models.worldbuild": "harness.models.world.build",
        "harness.models.keyframes": "harness.models.world.keyframes",
        "harness.models.placement": "harness.models.world.placement",
        "harness.models.robot_build": "harness.models.build.robot",
        "harness.models.compiler": "harness.models.build.compiler",
        "harness.models.setup": "harness.models.build.setup",
        "harness.models.actuators": "harness.models.build.actuators",
        "harness.models.drives": "harness.models.build.drives",
        "harness.models.passive": "harness.models.build.passive",
        "harness.models.inertia": "harness.models.build.inertia",
        "harness.models.decompose": "harness.models.build.decompose",
        "harness.models.selfcollision": "harness.models.build.selfcollision",
        "harness.models.drive_plugins": "harness.models.build.drive_plugins",
        "harness.models.base_hint": "harness.models.check.base_hint",
        "harness.models._check_cli": "harness.models.check._cli",
    }
)
