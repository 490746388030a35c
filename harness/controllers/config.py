"""The ros2_control controllers YAML: what a robot's controller manager loads.

The format is the one robot packages ship (``config/ros2_controllers.yaml``)::

    controller_manager:
      ros__parameters:
        update_rate: 100
        arm_controller:
          type: joint_trajectory_controller/JointTrajectoryController
        joint_state_broadcaster:
          type: joint_state_broadcaster/JointStateBroadcaster
    arm_controller:
      ros__parameters:
        joints: [joint1, joint2]
        command_interfaces: [position]

Node keys may carry a namespace or wildcard (``/**/controller_manager``, ``/robot/arm_controller``:
the last name counts); a ``/**`` section applies to every node. A controller's ``type`` may also
sit in its own section, and then the ``controller_manager:`` section may be left out (current
ros2_control: ``spawner --param-file``). Several files merge in order; ``$(var NAME)`` launch
substitutions are expanded from arguments (:mod:`harness.controllers.substitutions`).
Parameters keep their YAML nesting (``constraints: {goal_time: ...}``).
:func:`default_controllers` is the set every robot gets when no file is given.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, cast

import yaml  # type: ignore[import-untyped,unused-ignore]

from harness.controllers.errors import ControllersConfigError
from harness.controllers.substitutions import check_args, substitute, substitute_tree

__all__ = [
    "DEFAULT_UPDATE_RATE",
    "TYPE_FORWARD",
    "TYPE_GRIPPER",
    "TYPE_JOINT_STATE_BROADCASTER",
    "TYPE_JOINT_TRAJECTORY",
    "ControllerSpec",
    "ControllersConfig",
    "ControllersSource",
    "builtin_controllers",
    "default_controllers",
    "load_controllers",
]

DEFAULT_UPDATE_RATE = 100.0
"""controller_manager's ``update_rate`` default (Hz)."""
_MANAGER_GROUPS = frozenset({"hardware_components_initial_state"})
"""controller_manager parameters that are mappings, not controllers."""
TYPE_JOINT_STATE_BROADCASTER = "joint_state_broadcaster/JointStateBroadcaster"
TYPE_JOINT_TRAJECTORY = "joint_trajectory_controller/JointTrajectoryController"
TYPE_FORWARD = "forward_command_controller/ForwardCommandController"
TYPE_GRIPPER = "position_controllers/GripperActionController"
_PARAMS = "ros__parameters"
_MANAGER = "controller_manager"
_FINGER_WORDS = ("finger", "gripper", "jaw")


@dataclass(frozen=True)
class ControllerSpec:
    """One controller: its ``name`` (the node name: topics live under ``/<name>/``), its
    plugin ``type`` and its own ``ros__parameters``."""

    name: str
    type: str
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))

    def __reduce__(self) -> tuple[Any, ...]:
        # a scenario crosses to its worker process pickled; a mappingproxy does not pickle
        return (ControllerSpec, (self.name, self.type, dict(self.params)))


@dataclass(frozen=True)
class ControllersConfig:
    """What one controller manager loads: ``update_rate`` (Hz of simulation time) and the
    controllers in file order; ``source`` names where it came from (for messages)."""

    update_rate: float = DEFAULT_UPDATE_RATE
    controllers: tuple[ControllerSpec, ...] = ()
    source: str = "controllers"
    exclusive: bool = True
    """Whether it is a set a YAML or a robot file names (its controllers obey ros2_control's
    one-claim rule, and it replaces the harness's command topics); False for a set the
    harness makes (:func:`default_controllers`, :func:`builtin_controllers`), whose
    controllers share the joints through the robot's multiplexer (``command_mux``, added by
    the session) and which keeps the harness's ``joint_command`` and ``joint_trajectory``."""

    def to_json(self) -> str:
        """A canonical JSON text (the recording's metadata holds it)."""
        return json.dumps(
            {
                "update_rate": self.update_rate,
                "source": self.source,
                "exclusive": self.exclusive,
                "controllers": [
                    {"name": c.name, "type": c.type, "params": _plain(c.params)}
                    for c in self.controllers
                ],
            },
            sort_keys=True,
        )

    @classmethod
    def from_json(cls, text: str) -> ControllersConfig:
        """The inverse of :meth:`to_json`."""
        try:
            data = json.loads(text)
            return cls(
                float(data["update_rate"]),
                tuple(
                    ControllerSpec(str(c["name"]), str(c["type"]), dict(c["params"]))
                    for c in data["controllers"]
                ),
                str(data.get("source", "controllers")),
                bool(data.get("exclusive", True)),
            )
        except (ValueError, KeyError, TypeError) as exc:
            raise ControllersConfigError(f"controllers metadata is malformed: {exc}") from None


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _node_name(key: object) -> str:
    return str(key).rstrip("/").rsplit("/", 1)[-1]


def _one_manager(where: str, key: str, name: str, spaces: dict[str, str]) -> None:
    """Refuse a node configured under two explicit namespaces (``/rrbot_1/forward_position_
    controller`` and ``/rrbot_2/...``): that is several controller managers, one per namespace,
    and the harness gives one configuration to every robot of a session."""
    space = key.rstrip("/").rpartition("/")[0]
    if not space or "*" in space:
        return
    other = spaces.setdefault(name, space)
    if other != space:
        raise ControllersConfigError(
            f"{where}: {other}/{name} and {space}/{name}: several controller managers (one "
            "per namespace) are not supported: the harness gives one controllers configuration "
            "to every robot of a session"
        )


ControllersSource = str | Path | Mapping[str, Any]
"""One controllers YAML: a file path, YAML text, or the parsed mapping."""


def load_controllers(
    source: ControllersSource | Sequence[ControllersSource],
    args: Mapping[str, object] | None = None,
) -> ControllersConfig:
    """Read a controllers YAML: a file path, YAML text, or the parsed mapping (a scenario's
    ``controllers:`` key), or several of them merged in order as ``ros2 run ... --params-file
    A --params-file B`` merges them (a later file's parameter wins; nested mappings merge).
    ``args`` expands ``$(var NAME)`` (see :mod:`harness.controllers.substitutions`).
    :class:`ControllersConfigError` names the file and key at fault.

    The controllers are those a ``controller_manager:`` section lists (``name: {type: ...}`` or
    ``name.type: ...``) and every node section with its own ``type:`` (spawned with
    ``spawner --param-file``, as current ros2_control examples do); a file without a
    ``controller_manager:`` section is read so, with the manager's defaults."""
    sources: Sequence[ControllersSource] = (
        source if isinstance(source, list | tuple) else [cast(ControllersSource, source)]
    )
    if not sources:
        raise ControllersConfigError("controllers: no controllers file given")
    values = check_args(args or {}, "controllers_args")
    sections: dict[str, dict[str, Any]] = {}
    common: dict[str, Any] = {}
    names: list[str] = []
    spaces: dict[str, str] = {}
    for one in sources:
        where, data = _read(one, values)
        names.append(where)
        for key, body in data.items():
            if not isinstance(body, Mapping) or not isinstance(body.get(_PARAMS, {}), Mapping):
                raise ControllersConfigError(
                    f"{where}: {key}: expected a mapping with '{_PARAMS}:' under it"
                )
            params = dict(body.get(_PARAMS) or {})
            name = _node_name(key)
            _one_manager(where, str(key), name, spaces)
            _merge(common if name == "**" else sections.setdefault(name, {}), params)
    where = " + ".join(names)
    manager = sections.get(_MANAGER)
    typed = [n for n, p in sections.items() if n != _MANAGER and "type" in p]
    if manager is None and not typed:
        raise ControllersConfigError(
            f"{where}: no controllers: no node section has a 'type:' and there is no "
            f"'{_MANAGER}: {_PARAMS}:' section listing them"
        )
    manager = {**common, **(manager or {})}
    rate = manager.get("update_rate", DEFAULT_UPDATE_RATE)
    if isinstance(rate, bool) or not isinstance(rate, int | float) or not rate > 0:
        raise ControllersConfigError(
            f"{where}: {_MANAGER}.update_rate must be a number > 0 (Hz), not {rate!r}"
        )
    for key, value in list(manager.items()):  # ``name.type: plugin``, ROS's dotted spelling
        if isinstance(key, str) and key.endswith(".type") and isinstance(value, str):
            entry = manager.get(key.removesuffix(".type"))
            manager[key.removesuffix(".type")] = {
                **(entry if isinstance(entry, Mapping) else {}),
                "type": value,
            }
            del manager[key]
    specs: list[ControllerSpec] = []
    for name, entry in manager.items():
        if not isinstance(entry, Mapping) or name in _MANAGER_GROUPS:
            continue  # a manager parameter (update_rate, hardware_components_initial_state...)
        own = {**common, **sections.get(name, {})}
        ctype = entry.get("type", own.get("type"))
        if not isinstance(ctype, str) or "/" not in ctype:
            raise ControllersConfigError(
                f"{where}: {_MANAGER}.{name}.type must be a plugin name like "
                f"'{TYPE_JOINT_TRAJECTORY}', not {ctype!r}"
            )
        own.pop("type", None)
        specs.append(ControllerSpec(str(name), ctype, own))
    listed = {s.name for s in specs}
    for name in typed:
        if name in listed:
            continue
        own = {**common, **sections[name]}
        ctype = own.pop("type")
        if not isinstance(ctype, str) or "/" not in ctype:
            raise ControllersConfigError(
                f"{where}: {name}.type must be a plugin name like "
                f"'{TYPE_JOINT_TRAJECTORY}', not {ctype!r}"
            )
        specs.append(ControllerSpec(name, ctype, own))
    return ControllersConfig(float(rate), tuple(specs), where)


def _read(source: ControllersSource, args: Mapping[str, str]) -> tuple[str, Mapping[Any, Any]]:
    """One source's name (for messages) and its top-level mapping, substitutions expanded."""
    where = "controllers"
    data: Any
    if isinstance(source, Mapping):
        data = substitute_tree(source, args, where)
    else:
        text = str(source)
        path = Path(text)
        if isinstance(source, Path) or ("\n" not in text and ":" not in text):
            where = str(path)
            try:
                text = path.read_text("utf-8")
            except OSError as exc:
                raise ControllersConfigError(
                    f"{where}: cannot read the controllers file: {exc.strerror}"
                ) from None
        text = substitute(text, args, where)
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            at = f" (line {mark.line + 1})" if mark is not None else ""
            raise ControllersConfigError(f"{where}: not valid YAML{at}") from None
    if not isinstance(data, Mapping):
        raise ControllersConfigError(f"{where}: expected a mapping of node names at the top level")
    return where, data


def _merge(into: dict[str, Any], params: Mapping[Any, Any]) -> None:
    """``params`` over ``into``: a later value wins, nested mappings merge key by key (ROS
    parameters are flat dotted names; the nesting is only their YAML spelling)."""
    for key, value in params.items():
        old = into.get(key)
        if isinstance(old, Mapping) and isinstance(value, Mapping):
            merged = dict(old)
            _merge(merged, value)
            into[key] = merged
        else:
            into[key] = value


def _is_finger(joint: str) -> bool:
    lowered = joint.lower()
    return any(word in lowered for word in _FINGER_WORDS)


def default_controllers(
    joints: Sequence[str], control: Mapping[str, str], update_rate: float = DEFAULT_UPDATE_RATE
) -> ControllersConfig:
    """The set every robot gets: ``joint_state_broadcaster``; ``joint_trajectory_controller``
    over the arm joints (controllable joints not driven by effort, fingers excluded);
    ``gripper_controller`` on the first finger joint when the robot has fingers (a joint named
    ``*finger*``, ``*gripper*`` or ``*jaw*``); and ``forward_{position,velocity,effort}_controller``
    over every controllable joint (the forward command topics the session always had). The
    session adds the robot's multiplexer (``command_mux``: ``joint_command``,
    ``joint_trajectory``), through which they all share the joints."""
    fingers = [j for j in joints if _is_finger(j) and control.get(j) != "effort"]
    arm = [j for j in joints if j not in fingers and control.get(j) != "effort"]
    specs = [ControllerSpec("joint_state_broadcaster", TYPE_JOINT_STATE_BROADCASTER)]
    if arm:
        specs.append(
            ControllerSpec(
                "joint_trajectory_controller",
                TYPE_JOINT_TRAJECTORY,
                {
                    "joints": list(arm),
                    "command_interfaces": ["position"],
                    "state_interfaces": ["position", "velocity"],
                },
            )
        )
    if fingers:
        specs.append(
            ControllerSpec(
                "gripper_controller",
                TYPE_GRIPPER,
                {"joint": fingers[0]},
            )
        )
    specs += _forward_specs(joints)
    return ControllersConfig(update_rate, tuple(specs), "default controllers", exclusive=False)


def _forward_specs(joints: Sequence[str]) -> list[ControllerSpec]:
    return [
        ControllerSpec(
            f"forward_{interface}_controller",
            TYPE_FORWARD,
            {"joints": list(joints), "interface_name": interface},
        )
        for interface in ("position", "velocity", "effort")
    ]


def builtin_controllers(
    joints: Sequence[str], update_rate: float = DEFAULT_UPDATE_RATE
) -> ControllersConfig:
    """The harness's command topics without ros2_control's controllers
    (``controllers=False``): ``forward_{position,velocity,effort}_controller`` over every
    controllable joint (with the multiplexer's ``joint_command`` and ``joint_trajectory``,
    which the session adds)."""
    return ControllersConfig(
        update_rate, tuple(_forward_specs(joints)), "harness command topics", exclusive=False
    )
