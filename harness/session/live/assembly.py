"""The parts :class:`~harness.session.Session`'s constructor assembles, each call made once:
the run it loads with its options resolved (:func:`resolve_run`), the core with its port and
event sinks (:func:`build_core`), and the ROS 2 side (:func:`ros2_domain`,
:func:`start_ros2`). The single steps live in :mod:`harness.session.live.startup`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from harness.events import EventHub, Sink
from harness.models import LoadedRobot, LoadedWorld
from harness.recording import Recorder
from harness.session.core.bridge import SessionBridge
from harness.session.core.control import resolve_default
from harness.session.core.engine import SessionCore
from harness.session.core.options import CoreOptions, LoadOptions, TransportOptions
from harness.session.live.ports import Port
from harness.session.live.startup import load_run, open_port
from harness.session.live.upstream import UpstreamStats

__all__ = ["build_core", "resolve_run", "ros2_domain", "start_ros2"]


def ros2_domain(transport: TransportOptions) -> int | None:
    """The ROS_DOMAIN_ID of the ROS 2 side (``ros2=True``: chosen now), else None."""
    if not transport.ros2:
        return None
    from harness.ros2 import choose_domain_id

    return choose_domain_id()


def resolve_run(
    robot: str | Path | LoadedRobot | None, load: LoadOptions, options: CoreOptions
) -> tuple[LoadedRobot | LoadedWorld, CoreOptions]:
    """What the session runs (:func:`~harness.session.live.startup.load_run`) and its options with
    the ``controllers`` default resolved for it."""
    loaded = load_run(robot, load, options.namespace, options.sensors)
    controllers = resolve_default(options.controllers, loaded)
    return loaded, dataclasses.replace(options, controllers=controllers)


def build_core(
    loaded: LoadedRobot | LoadedWorld,
    options: CoreOptions,
    recorder: Recorder | None,
    hub: EventHub,
    transport: TransportOptions,
    sinks: Iterable[Sink],
    *,
    core: SessionCore | None = None,
) -> tuple[SessionCore, Port, UpstreamStats | None]:
    """The sans-I/O core (or ``core``, one already running: a resumed run), the port its
    bridge talks through (not started; client mode: with what the upstream link counts) and
    ``sinks`` added to ``hub`` after the recording's."""
    if core is None:
        core = SessionCore(loaded, options, recorder=recorder, hub=hub)
    assert core.bridge is not None
    port, upstream = open_port(core.bridge, transport)
    for sink in sinks:
        hub.add_sink(sink)
    return core, port, upstream


def start_ros2(
    url: str,
    bridge: SessionBridge,
    domain_id: int,
    call: Callable[[Callable[[], Any]], Any],
) -> Any:
    """Start the ROS 2 gateway (:mod:`harness.ros2`) as a client of ``url`` on ``domain_id``,
    offering what ``bridge`` serves (read through ``call``, on the session's thread)."""
    from harness.ros2 import Ros2Gateway
    from harness.rosbridge.offer import offer_of

    offer = call(lambda: offer_of(bridge))
    return Ros2Gateway.start(url, offer, domain_id)
