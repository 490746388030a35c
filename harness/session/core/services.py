"""The ``/harness/*`` services a session core serves to its clients.

``/harness/step`` (lockstep stepping, optionally until a topic was published),
``/harness/reset`` (back to the initial state), ``/harness/pause`` (pause or resume a
free-running clock) and ``/harness/get_state``. :class:`HarnessServices` answers them from a
:class:`ServiceHost` (the :class:`~harness.session.core.SessionCore`) and registers them on
a :class:`~harness.session.core.bridge.Graph` (:meth:`HarnessServices.serve`). A service call is a
client frame, so it is recorded as one: reset and pause are given the core's unrecorded forms
(the Python API's :meth:`~harness.session.core.SessionCore.reset` records a marker first).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

from harness.session.core.bridge import Graph
from harness.session.core.options import CoreOptions
from harness.session.core.stepping import PublishCounter, parse_step_request, run_step
from harness.session.core.topics import stamp
from harness.sim import Simulation
from harness.vocabulary import ClockMode

__all__ = [
    "SERVICE_GET_STATE",
    "SERVICE_PAUSE",
    "SERVICE_RESET",
    "SERVICE_STEP",
    "HarnessServices",
    "ServiceHost",
]

SERVICE_STEP = "/harness/step"
SERVICE_RESET = "/harness/reset"
SERVICE_PAUSE = "/harness/pause"
SERVICE_GET_STATE = "/harness/get_state"


class ServiceHost(Protocol):
    """What the services read and drive of the session core."""

    @property
    def options(self) -> CoreOptions: ...

    @property
    def sim(self) -> Simulation: ...

    @property
    def clock(self) -> ClockMode: ...

    @property
    def paused(self) -> bool: ...

    @property
    def publish_counts(self) -> PublishCounter: ...

    def check_running(self) -> None: ...

    def advance(self) -> None: ...

    def joint_state(self) -> dict[str, Any]: ...


class HarnessServices:
    """The handlers of the ``/harness/*`` services of one core. ``reset()`` and
    ``pause(paused)`` do what the services ask without recording a marker and return the
    text the service answers."""

    def __init__(
        self, host: ServiceHost, *, reset: Callable[[], str], pause: Callable[[bool], str]
    ) -> None:
        self.host = host
        self._reset = reset
        self._pause = pause

    def serve(self, graph: Graph) -> None:
        """Serve every ``/harness/*`` service on ``graph``."""
        graph.serve(SERVICE_STEP, "harness_msgs/srv/Step", self.step)
        graph.serve(SERVICE_RESET, "std_srvs/srv/Trigger", self.reset)
        graph.serve(SERVICE_PAUSE, "std_srvs/srv/SetBool", self.pause)
        graph.serve(SERVICE_GET_STATE, "harness_msgs/srv/GetState", self.get_state)

    def step(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        """``/harness/step``: the steps asked for (a clear error when the request is wrong
        or the simulation has failed); answers the simulation time reached."""
        host = self.host
        step = parse_step_request(request, host.options.max_step_request)
        host.check_running()
        run_step(step, host.advance, host.publish_counts)
        return {"sim_time": stamp(host.sim.sim_time_ns)}

    def reset(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        """``/harness/reset``: back to the initial state, step numbering continuing."""
        return {"success": True, "message": self._reset()}

    def pause(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        """``/harness/pause``: pause (``data`` true) or resume a free-running clock."""
        return {"success": True, "message": self._pause(bool(request["data"]))}

    def get_state(self, request: Mapping[str, Any]) -> Mapping[str, Any]:
        """``/harness/get_state``: the step, time, clock, joint state and joints."""
        host = self.host
        sim = host.sim
        return {
            "step": sim.step_index,
            "sim_time": stamp(sim.sim_time_ns),
            "clock": host.clock,
            "paused": host.paused,
            "joint_state": host.joint_state(),
            "controllable_joints": list(sim.joint_names),
        }
