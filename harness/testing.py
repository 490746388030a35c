"""Helpers for tests of robot software against a harness session.

- :class:`BridgeTestClient` (:func:`connect`): a small *synchronous* rosbridge v2 client:
  publish, subscribe, call services, send action goals (:meth:`BridgeTestClient.send_goal`:
  a :class:`GoalHandle` with its feedback, its result and cancel), and step a lockstep session
  through ``/harness/step``.
  :meth:`Subscription.wait_for_message` waits in **simulation time**: on a lockstep session it
  steps one step at a time until the message is there; on a free-running clock it follows
  ``/clock``. Nothing here sleeps on the wall clock: the only wall-clock bound is
  ``io_timeout``, a guard against a dead server, never a way to let time pass.
- :func:`advance`: step a session by an amount of simulation time.

For waits on the session's own state use ``session.run_until(predicate, sim_timeout=...)``.

Determinism: frames of one connection are applied in the order they were sent, and the reply
to a service call comes after everything published during it. So ``client.step(n)`` after
``client.publish(...)`` applies the command before the steps, and the messages published
during the steps are delivered before ``step`` returns. Before stepping from Python
(``session.step``) after publishing from a client, call :meth:`BridgeTestClient.sync`.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING, Any, ClassVar

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI
from websockets.sync.client import ClientConnection
from websockets.sync.client import connect as ws_connect

from harness.errors import BridgeError

if TYPE_CHECKING:
    from harness.session import Session

__all__ = [
    "ActionGoalFailed",
    "BridgeTestClient",
    "GoalHandle",
    "GoalResult",
    "ServiceCallFailed",
    "Subscription",
    "TestClientError",
    "TestClientTimeout",
    "advance",
    "connect",
]

Message = dict[str, Any]


class TestClientError(BridgeError):
    """The test client could not talk to the bridge (connection lost, bad frame)."""

    __test__ = False  # not a pytest test class


class ServiceCallFailed(TestClientError):
    """A service call was answered with ``result: false``."""


class ActionGoalFailed(TestClientError):
    """An action goal was answered with ``result: false`` (no such action, a goal that does
    not convert, a limit): the bridge's reason is the message."""


class TestClientTimeout(TestClientError):
    """A wait ran out of simulation time (or, for a dead server, of ``io_timeout``)."""

    __test__ = False


def _stamp_ns(stamp: Mapping[str, Any]) -> int:
    return int(stamp.get("sec", 0)) * 1_000_000_000 + int(stamp.get("nanosec", 0))


class Subscription:
    """Messages received on one topic, oldest first. :attr:`messages` keeps every one;
    :meth:`wait_for_message` consumes them in order."""

    def __init__(self, client: BridgeTestClient, topic: str, type: str | None) -> None:
        self.client = client
        self.topic = topic
        self.type = type
        self.messages: list[Message] = []
        """Every message received, in order."""
        self._unread: deque[Message] = deque()

    def _deliver(self, msg: Message) -> None:
        self.messages.append(msg)
        self._unread.append(msg)

    @property
    def latest(self) -> Message | None:
        """The last message received, or None."""
        with self.client._cond:
            return self.messages[-1] if self.messages else None

    def _take(self, predicate: Callable[[Message], bool] | None) -> Message | None:
        while self._unread:
            msg = self._unread.popleft()
            if predicate is None or predicate(msg):
                return msg
        return None

    def wait_for_message(
        self,
        *,
        sim_timeout: float,
        predicate: Callable[[Message], bool] | None = None,
    ) -> Message:
        """The next unread message (matching ``predicate``), waiting up to ``sim_timeout``
        seconds of simulation time. Lockstep sessions are stepped one step at a time until it
        arrives; free-running clocks are followed on ``/clock``. Raises
        :class:`TestClientTimeout` naming the simulation time reached."""
        client = self.client
        with client._cond:
            found = self._take(predicate)
        if found is not None:
            return found
        msg: Message = client._wait_sim(
            lambda: self._take(predicate), sim_timeout, f"a message on {self.topic}"
        )
        return msg


@dataclass(frozen=True)
class GoalResult:
    """An action goal's end: ``status`` (``action_msgs/msg/GoalStatus``: 4 succeeded,
    5 canceled, 6 aborted) and the result message's ``values``."""

    status: int
    values: Message

    SUCCEEDED: ClassVar[int] = 4
    CANCELED: ClassVar[int] = 5
    ABORTED: ClassVar[int] = 6

    @property
    def succeeded(self) -> bool:
        return self.status == self.SUCCEEDED


class GoalHandle:
    """One action goal sent by :meth:`BridgeTestClient.send_goal`. :attr:`feedback` holds
    every feedback message so far (oldest first); :meth:`result` waits for the end in
    simulation time (stepping a lockstep session); :meth:`cancel` asks the server to cancel."""

    __test__ = False

    def __init__(self, client: BridgeTestClient, action: str, goal_id: str) -> None:
        self.client = client
        self.action = action
        self.id = goal_id
        self.feedback: list[Message] = []
        """The feedback messages received (read under the client's lock or between calls)."""
        self._read = 0
        self._end: Message | None = None

    def _deliver(self, frame: Message) -> None:
        if frame.get("op") == "action_feedback":
            values = frame.get("values")
            self.feedback.append(values if isinstance(values, dict) else {"value": values})
        else:
            self._end = frame

    @property
    def done(self) -> bool:
        """Whether the result (or the bridge's refusal) has arrived."""
        with self.client._cond:
            return self._end is not None

    def wait_for_feedback(self, *, sim_timeout: float) -> Message:
        """The next feedback message not returned before, waiting up to ``sim_timeout``
        seconds of simulation time; raises :class:`TestClientTimeout` (also when the goal
        ends without more feedback)."""

        def probe() -> Message | None:
            if self._read < len(self.feedback):
                self._read += 1
                return self.feedback[self._read - 1]
            if self._end is not None:
                raise TestClientTimeout(f"{self.action}: the goal ended without more feedback")
            return None

        msg: Message = self.client._wait_sim(probe, sim_timeout, f"feedback from {self.action}")
        return msg

    def result(self, *, sim_timeout: float) -> GoalResult:
        """The goal's end, waiting up to ``sim_timeout`` seconds of simulation time; raises
        :class:`ActionGoalFailed` when the bridge refused the goal, :class:`TestClientTimeout`
        when it does not end in time."""
        end: Message = self.client._wait_sim(
            lambda: self._end, sim_timeout, f"the result of {self.action}"
        )
        if not end.get("result", False):
            raise ActionGoalFailed(f"{self.action}: {end.get('values')}")
        values = end.get("values")
        return GoalResult(
            int(end.get("status", 0)), values if isinstance(values, dict) else {"value": values}
        )

    def cancel(self) -> None:
        """Ask the action server to cancel the goal (it takes effect at the session's next
        step boundary; :meth:`result` then says how the goal ended)."""
        self.client._send({"op": "cancel_action_goal", "id": self.id, "action": self.action})

    def __repr__(self) -> str:
        return f"GoalHandle({self.action!r}, {self.id!r}, {'done' if self._end else 'active'})"


class BridgeTestClient:
    """A synchronous rosbridge v2 client for tests (a context manager; :meth:`close`).

    ``lockstep``: the session's clock moves only when stepped (the default in tests); waits
    step it through ``/harness/step``. Otherwise waits follow ``/clock``. ``io_timeout``:
    wall-clock seconds to wait for a reply before declaring the server dead.
    """

    __test__ = False

    def __init__(self, url: str, *, lockstep: bool = True, io_timeout: float = 30.0) -> None:
        self.url = url
        self.lockstep = lockstep
        self.io_timeout = io_timeout
        self.statuses: list[Message] = []
        """Every ``status`` frame the bridge sent this client."""
        self._cond = threading.Condition()
        self._ids = itertools.count(1)
        self._subs: dict[str, list[Subscription]] = {}
        self._replies: dict[str, Message] = {}
        self._goals: dict[str, GoalHandle] = {}
        self._advertised: dict[str, str] = {}
        self._sim_time_ns: int | None = None
        self._clock_sub: Subscription | None = None
        self._closed = False
        self._error: BaseException | None = None
        self._stack = contextlib.ExitStack()
        try:
            # Entered as a context manager: websockets >= 17 deprecates plain connect().
            self._ws: ClientConnection = self._stack.enter_context(
                ws_connect(url, open_timeout=io_timeout, close_timeout=2, max_size=None)
            )
        except (OSError, InvalidHandshake, InvalidURI, TimeoutError) as exc:
            raise TestClientError(f"cannot connect to {url}: {exc}") from None
        self._reader = threading.Thread(target=self._read, name="harness-test-client", daemon=True)
        self._reader.start()

    # -- lifecycle --------------------------------------------------------------------------

    def __enter__(self) -> BridgeTestClient:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection and join the reader thread (idempotent)."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
        self._stack.close()
        self._reader.join()

    def _read(self) -> None:
        try:
            while True:
                raw = self._ws.recv()
                text = raw.decode() if isinstance(raw, bytes) else raw
                try:
                    frame = json.loads(text)
                except ValueError:
                    continue
                if isinstance(frame, dict):
                    self._dispatch(frame)
        except ConnectionClosed:
            pass
        except Exception as exc:
            with self._cond:
                self._error = exc
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def _dispatch(self, frame: Message) -> None:
        op = frame.get("op")
        with self._cond:
            if op == "publish":
                msg = frame.get("msg", {})
                for sub in self._subs.get(str(frame.get("topic")), ()):
                    sub._deliver(msg)
            elif op == "service_response":
                self._replies[str(frame.get("id"))] = frame
            elif op in ("action_feedback", "action_result"):
                goal = self._goals.get(str(frame.get("id")))
                if goal is None:
                    return
                goal._deliver(frame)
                if op == "action_result":
                    del self._goals[goal.id]
            elif op == "status":
                self.statuses.append(frame)
            else:
                return
            self._cond.notify_all()

    def _send(self, frame: Mapping[str, Any]) -> None:
        if self._closed:
            raise TestClientError(f"{self.url}: the connection is closed")
        try:
            self._ws.send(json.dumps(frame))
        except ConnectionClosed:
            raise TestClientError(f"{self.url}: the connection was closed") from None

    def _wait_wall(self, ready: Callable[[], bool], what: str) -> None:
        """Wait (holding ``_cond``) until ``ready()``; wall clock only guards a dead server."""
        if not self._cond.wait_for(lambda: ready() or self._closed, self.io_timeout):
            raise TestClientTimeout(f"{self.url}: no {what} within {self.io_timeout} s (wall)")
        if not ready():
            raise TestClientError(f"{self.url}: the connection closed while waiting for {what}")

    # -- topics -----------------------------------------------------------------------------

    def subscribe(self, topic: str, type: str | None = None) -> Subscription:
        """Subscribe to ``topic`` (``type``, e.g. ``sensor_msgs/msg/JointState``, optional
        when the topic is already advertised). Messages are kept from now on."""
        sub = Subscription(self, topic, type)
        with self._cond:
            self._subs.setdefault(topic, []).append(sub)
        frame: dict[str, Any] = {"op": "subscribe", "topic": topic, "id": self._id("subscribe")}
        if type is not None:
            frame["type"] = type
        self._send(frame)
        return sub

    def publish(self, topic: str, type: str, msg: Mapping[str, Any]) -> None:
        """Publish ``msg`` (advertising ``topic`` as ``type`` on first use). It takes effect at
        the session's next step boundary, after every frame this client sent before it."""
        if self._advertised.get(topic) != type:
            self._send({"op": "advertise", "topic": topic, "type": type, "id": self._id("adv")})
            self._advertised[topic] = type
        self._send({"op": "publish", "topic": topic, "msg": dict(msg)})

    # -- services ---------------------------------------------------------------------------

    def call_service(
        self, service: str, args: Mapping[str, Any] | None = None, *, type: str | None = None
    ) -> Message:
        """Call ``service`` and return its response values; raises :class:`ServiceCallFailed`
        when the bridge answers ``result: false``."""
        call_id = self._id(f"call_service:{service}")
        frame: dict[str, Any] = {
            "op": "call_service",
            "service": service,
            "args": dict(args or {}),
            "id": call_id,
        }
        if type is not None:
            frame["type"] = type
        self._send(frame)
        with self._cond:
            self._wait_wall(lambda: call_id in self._replies, f"answer from {service}")
            reply = self._replies.pop(call_id)
        if not reply.get("result", False):
            raise ServiceCallFailed(f"{service}: {reply.get('values')}")
        values = reply.get("values", {})
        return values if isinstance(values, dict) else {"value": values}

    # -- actions ----------------------------------------------------------------------------

    def send_goal(
        self,
        action: str,
        action_type: str,
        goal: Mapping[str, Any],
        *,
        feedback: bool = True,
    ) -> GoalHandle:
        """Send ``goal`` to ``action`` (``action_type``, e.g.
        ``control_msgs/action/FollowJointTrajectory``); returns its :class:`GoalHandle` at
        once. Like a publish, the goal takes effect at the session's next step boundary;
        ``feedback``: ask for feedback messages."""
        goal_id = self._id(f"send_action_goal:{action}")
        handle = GoalHandle(self, action, goal_id)
        with self._cond:
            self._goals[goal_id] = handle
        self._send(
            {
                "op": "send_action_goal",
                "id": goal_id,
                "action": action,
                "action_type": action_type,
                "args": dict(goal),
                "feedback": feedback,
            }
        )
        return handle

    def step(self, n: int = 1) -> int:
        """Advance a lockstep session by ``n`` steps (``/harness/step``); returns the
        simulation time in ns once they are done (``n=0``: the current time)."""
        if not isinstance(n, int) or n < 0:
            raise TestClientError(f"step count must be an integer >= 0, not {n!r}")
        values = self.call_service("/harness/step", {"steps": n})
        now = _stamp_ns(values.get("sim_time", {}))
        self._sim_time_ns = now
        return now

    def sync(self) -> None:
        """Return once every frame sent before has been applied by the session (one service
        round trip); use it before stepping from Python after publishing."""
        self.call_service("/harness/get_state")

    def state(self) -> Message:
        """``/harness/get_state``: step, sim_time, clock, paused, joint_state."""
        return self.call_service("/harness/get_state")

    # -- sim-time waits ---------------------------------------------------------------------

    def wait_until(
        self, predicate: Callable[[], bool], *, sim_timeout: float, what: str = "the condition"
    ) -> None:
        """Wait until ``predicate()`` (called with the client's lock held, e.g. over
        subscriptions' :attr:`~Subscription.messages`) holds, up to ``sim_timeout`` seconds of
        simulation time."""
        with self._cond:
            if predicate():
                return
        self._wait_sim(lambda: True if predicate() else None, sim_timeout, what)

    def _wait_sim(
        self, probe: Callable[[], Message | bool | None], sim_timeout: float, what: str
    ) -> Any:
        if not (math.isfinite(sim_timeout) and sim_timeout >= 0):
            raise TestClientError(f"sim_timeout must be >= 0 s, not {sim_timeout!r}")
        budget_ns = round(sim_timeout * 1e9)
        if self.lockstep:
            start = self.step(0)
            while True:
                with self._cond:
                    found = probe()
                if found is not None:
                    return found
                now = self._sim_time_ns or 0
                if now - start >= budget_ns:
                    raise TestClientTimeout(
                        f"{what}: not within {sim_timeout:g} s of simulation time "
                        f"(sim time now {now / 1e9:.6f} s)"
                    )
                self.step(1)
        clock = self._clock()
        with self._cond:
            self._wait_wall(lambda: bool(clock.messages), "message on /clock")
            start = _stamp_ns(clock.messages[-1].get("clock", {}))
            seen = len(clock.messages)
            progress = time.monotonic()
            while True:
                found = probe()
                if found is not None:
                    return found
                now = _stamp_ns(clock.messages[-1].get("clock", {}))
                if now - start >= budget_ns:
                    raise TestClientTimeout(
                        f"{what}: not within {sim_timeout:g} s of simulation time "
                        f"(sim time now {now / 1e9:.6f} s)"
                    )
                if self._closed:
                    raise TestClientError(f"{self.url}: the connection closed waiting for {what}")
                if len(clock.messages) > seen:
                    seen, progress = len(clock.messages), time.monotonic()
                elif time.monotonic() - progress > self.io_timeout:
                    raise TestClientTimeout(
                        f"{self.url}: simulation time stopped at {now / 1e9:.6f} s for "
                        f"{self.io_timeout} s (wall) while waiting for {what}"
                    )
                self._cond.wait(self.io_timeout)

    def _clock(self) -> Subscription:
        if self._clock_sub is None:
            self._clock_sub = self.subscribe("/clock", "rosgraph_msgs/msg/Clock")
        return self._clock_sub

    def _id(self, prefix: str) -> str:
        return f"{prefix}:{next(self._ids)}"

    def __repr__(self) -> str:
        return f"BridgeTestClient({self.url!r}, {'closed' if self._closed else 'open'})"


def connect(url: str, *, lockstep: bool = True, io_timeout: float = 30.0) -> BridgeTestClient:
    """Connect a :class:`BridgeTestClient` to ``url`` (e.g. the ``rosbridge_url`` fixture)."""
    return BridgeTestClient(url, lockstep=lockstep, io_timeout=io_timeout)


def advance(session: Session, sim_seconds: float) -> int:
    """Step a lockstep ``session`` by ``sim_seconds`` of simulation time (rounded up to whole
    steps); returns the step reached."""
    if not (math.isfinite(sim_seconds) and sim_seconds >= 0):
        raise TestClientError(f"sim_seconds must be >= 0, not {sim_seconds!r}")
    return session.step(math.ceil(round(sim_seconds * 1e9) / session.dt_ns))
