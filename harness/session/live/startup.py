"""What :class:`~harness.session.Session`'s constructor builds before its thread starts, one
function per concern: the options objects from its arguments (:func:`option_groups`), the
robot or world it runs (:func:`load_run`), the recorder with the run's metadata
(:func:`open_recorder`) and the port its bridge talks through (:func:`open_port`: an embedded
server, or a client of an external rosbridge server).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from harness.models import (
    BaseKind,
    ControlMode,
    LoadedRobot,
    LoadedWorld,
    MeshCollision,
    RobotSpec,
    SelfCollision,
    WorldObject,
    check_mesh_collision,
    load_robot,
    load_world,
)
from harness.recording import Recorder, describe_run
from harness.session.core.bridge import SessionBridge
from harness.session.core.options import (
    CoreOptions,
    LoadOptions,
    RecordOptions,
    TransportOptions,
    group_keywords,
)
from harness.session.errors import SessionConfigError
from harness.session.live.ports import Port, ServerPort
from harness.session.live.upstream import UpstreamPort, UpstreamStats, redact

__all__ = ["load_run", "open_port", "open_recorder", "option_groups"]


def option_groups(
    keywords: Mapping[str, Any],
    options: CoreOptions | None,
    transport: TransportOptions | None,
    record: RecordOptions | str | Path | None,
    load: LoadOptions | None,
) -> tuple[CoreOptions, TransportOptions, RecordOptions, LoadOptions]:
    """The session's four options objects: those given, the others built from the keyword
    arguments (:func:`~harness.session.core.options.group_keywords`); ``record`` may be the MCAP
    path."""
    if isinstance(record, str | Path):
        record = RecordOptions(record_to=record)
    groups = group_keywords(
        keywords, {"options": options, "transport": transport, "record": record, "load": load}
    )
    options = groups["options"]
    transport = groups["transport"]
    record = groups["record"]
    load = groups["load"]
    assert isinstance(options, CoreOptions)
    assert isinstance(transport, TransportOptions)
    assert isinstance(record, RecordOptions)
    assert isinstance(load, LoadOptions)
    return options, transport, record, load


def load_run(
    robot: str | Path | LoadedRobot | None,
    load: LoadOptions,
    namespace: str,
    sensors: Sequence[Mapping[str, Any]] = (),
) -> LoadedRobot | LoadedWorld:
    """What a session runs: ``robot`` loaded (or as given), or the world of ``load.robots``;
    options that do not apply to what was given raise :class:`SessionConfigError`. A robot
    the session loads whose sensors render (its files' or ``sensors``: a camera) is loaded
    with its visual geoms, which the camera draws."""
    return _load(
        robot,
        load.robots,
        load.objects,
        load.mode,
        load.scene,
        namespace,
        load.robot_args,
        _load_options(load.self_collision, load.base, load.strict, load.srdf, load.pose),
        sensors,
        mesh_collision=load.mesh_collision,
    )


def _renders(sources: Mapping[str, bytes], sensors: Sequence[Mapping[str, Any]]) -> bool:
    """Whether a sensor the robot's ``sources`` declare, or one of ``sensors``, renders.
    Unknown types are left to the sensor suite, which names them."""
    from harness.sensors import declared_in_sources, kind_of, known_types

    types = [str(item.get("type", "")) for item in sensors if isinstance(item, Mapping)]
    types += [spec.type for spec in declared_in_sources(sources)]
    known = known_types()
    return any(kind_of(t).renders for t in types if t in known)


def _pose_metadata(loaded: LoadedRobot | LoadedWorld, load: LoadOptions) -> dict[str, str]:
    """``pose``: where a robot the session placed (``pose=``) stands, ``[x, y, z, qw, qx, qy,
    qz]``, so that a rebuild places it there (none without ``pose=``: recordings keep their
    bytes)."""
    if load.pose is None or not isinstance(loaded, LoadedRobot):
        return {}
    place = loaded.placement
    return {"pose": json.dumps([*place.xyz, *place.quat])}


def open_recorder(
    path: Path,
    loaded: LoadedRobot | LoadedWorld,
    options: CoreOptions,
    transport: TransportOptions,
    record: RecordOptions,
    load: LoadOptions,
    ros_domain_id: int | None,
) -> Recorder:
    """The session's recorder at ``path``, its metadata describing the run (the robots, the
    options, the transport)."""
    robots = load.robots
    connect_to = transport.connect_to
    description = describe_run(
        loaded,
        seed=options.seed,
        scenario=record.scenario,
        specs=robots if isinstance(robots, Sequence) else None,
        objects=load.objects,
        extra={
            **options.to_metadata(),
            "transport": "server" if connect_to is None else "client",
            **({"upstream": redact(connect_to)} if connect_to is not None else {}),
            **({"ros_domain_id": str(ros_domain_id)} if ros_domain_id is not None else {}),
            **_pose_metadata(loaded, load),
        },
    )
    return Recorder(
        path,
        metadata=description.metadata,
        attachments=description.attachments,
        state_every=options.state_every,
    )


def open_port(
    bridge: SessionBridge, transport: TransportOptions
) -> tuple[Port, UpstreamStats | None]:
    """The port ``bridge`` talks through (not started): an embedded server, or in client mode
    (``connect_to``) the link to the external server with what it counts."""
    if transport.connect_to is not None:
        upstream = UpstreamPort(
            bridge, transport.connect_to, allow_refused=transport.connect_allow_refused
        )
        return upstream, upstream.stats
    server = ServerPort(bridge, host=transport.host, port=transport.port, token=transport.token)
    return server, None


def _load_options(
    self_collision: SelfCollision | None,
    base: BaseKind | None,
    strict: bool,
    srdf: str | Path | None = None,
    pose: Any = None,
) -> dict[str, Any]:
    """The robot load options a session was given (none left at their default)."""
    options: dict[str, Any] = {}
    if pose is not None:
        options["pose"] = pose
    if self_collision is not None:
        options["self_collision"] = self_collision
    if srdf is not None:
        options["srdf"] = srdf
    if base is not None:
        options["base"] = base
    if strict:
        options["strict"] = True
    return options


def _load(
    robot: str | Path | LoadedRobot | None,
    robots: Sequence[RobotSpec] | LoadedWorld | None,
    objects: Sequence[WorldObject],
    mode: ControlMode | str | Mapping[str, ControlMode | str] | None,
    scene: str | Path | None,
    namespace: str,
    robot_args: Mapping[str, Any] | None = None,
    load_options: Mapping[str, Any] | None = None,
    sensors: Sequence[Mapping[str, Any]] = (),
    mesh_collision: MeshCollision = "decompose",
) -> LoadedRobot | LoadedWorld:
    """What a session runs: ``robot`` loaded (or as given), or the world of ``robots``."""
    mesh_collision = check_mesh_collision(mesh_collision, "Session: mesh_collision")
    given = robots if isinstance(robots, LoadedWorld) else robot
    if isinstance(given, LoadedRobot | LoadedWorld) and given.mesh_collision != mesh_collision:
        raise SessionConfigError(
            f"mesh_collision={mesh_collision!r} applies when the session loads the model: this "
            f"one was loaded with {given.mesh_collision!r} (pass it to load_robot/load_world)"
        )
    if robot_args and (robots is not None or isinstance(robot, LoadedRobot)):
        raise SessionConfigError(
            "robot_args apply when the session loads robot=; give each RobotSpec its "
            "robot_args, or load_robot(..., robot_args=...) yourself"
        )
    if load_options and (robots is not None or isinstance(robot, LoadedRobot)):
        raise SessionConfigError(
            f"{', '.join(load_options)} apply when the session loads robot=; give each "
            "RobotSpec its own, or pass them to load_robot(...) yourself"
        )
    if robots is None:
        if objects:
            raise SessionConfigError(
                "objects are added to a world: give the robots as robots=[RobotSpec(...)]"
            )
        if isinstance(robot, LoadedRobot):
            if mode is not None:
                raise SessionConfigError(
                    "mode applies only when the session loads the robot: this LoadedRobot "
                    "was built with its control modes (load_robot(..., control=...))"
                )
            return robot
        loaded = load_robot(
            "demo" if robot is None else robot,
            control=mode or "position",
            scene=scene,
            robot_args=robot_args,
            mesh_collision=mesh_collision,
            **(load_options or {}),
        )
        if not _renders(loaded.sources, sensors):
            return loaded
        # A camera draws the visual geoms; which sensors a (xacro) robot declares is known
        # once it is expanded, so such a robot is loaded a second time, with its visuals.
        return load_robot(
            "demo" if robot is None else robot,
            control=mode or "position",
            scene=scene,
            robot_args=robot_args,
            visuals=True,
            mesh_collision=mesh_collision,
            **(load_options or {}),
        )
    if robot is not None:
        raise SessionConfigError("give robot= (one robot) or robots= (a world), not both")
    if mode is not None:
        raise SessionConfigError(
            "mode applies to robot=; with robots= give each RobotSpec its control"
        )
    if namespace:
        raise SessionConfigError(
            f"namespace {namespace!r} applies to robot=; with robots= give each RobotSpec its "
            "namespace"
        )
    if isinstance(robots, LoadedWorld):
        if objects or scene is not None:
            raise SessionConfigError(
                "scene and objects are part of a LoadedWorld already: pass them to load_world"
            )
        return robots
    specs = list(robots)
    if not specs or not all(isinstance(spec, RobotSpec) for spec in specs):
        raise SessionConfigError(
            f"robots must be a non-empty list of RobotSpec or a LoadedWorld, not {robots!r}"
        )
    return load_world(specs, scene=scene, objects=objects, mesh_collision=mesh_collision)
