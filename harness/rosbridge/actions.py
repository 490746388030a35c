"""Actions on the bridge: goals routed to a client's or an in-process action server,
feedback, results, cancels and timeouts (a room of :class:`~harness.rosbridge.Bridge`, mixed
into it)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Final

from harness.rosbridge.convert import dumps, from_json
from harness.rosbridge.deadlines import bounded_timeout
from harness.rosbridge.errors import ConversionError, FrameError
from harness.rosbridge.frames import BAD_INPUT, BridgeHost, field_of, kind_of, name_field
from harness.rosbridge.graph import HARNESS_NODE, ActionEntry, normalize
from harness.rosbridge.limits import over_pending_limit

__all__ = ["GOAL_ABORTED", "GOAL_CANCELED", "GOAL_SUCCEEDED", "ActionGoal", "ActionOps"]

GOAL_SUCCEEDED: Final = 4
GOAL_CANCELED: Final = 5
GOAL_ABORTED: Final = 6


class ActionGoal:
    """One goal of an in-process action server: send :meth:`feedback`, then :meth:`finish`
    once. ``cancel_requested`` turns true on ``cancel_action_goal``; ``on_cancel`` (if set)
    is called then, else the goal finishes as canceled at once."""

    def __init__(
        self,
        bridge: ActionOps,
        key: int,
        action: str,
        type: str,
        goal: dict[str, Any],
        connection: int,
    ) -> None:
        self._bridge = bridge
        self.key = key
        self.action = action
        self.type = type
        self.goal = goal
        self.connection = connection
        self.cancel_requested = False
        self.on_cancel: Callable[[ActionGoal], None] | None = None
        self.done = False

    def feedback(self, values: Mapping[str, Any]) -> None:
        """Send feedback (validated against the feedback type) to the goal's client."""
        self._bridge._goal_feedback(self.key, values)

    def finish(self, result: Mapping[str, Any], status: int = GOAL_SUCCEEDED) -> None:
        """Send the result: status 4 succeeded, 5 canceled, 6 aborted."""
        self._bridge._goal_result(self.key, result, status, True)


@dataclass
class _PendingGoal:
    caller: int
    caller_id: Any
    spelled: str
    action: ActionEntry
    feedback: bool
    provider_id: str | None
    goal: ActionGoal | None = None


class ActionOps(BridgeHost):
    """The action ops (``send_action_goal``, ``cancel_action_goal``, ``action_feedback``,
    ``action_result``, ``advertise_action``, ``unadvertise_action``) and in-process action
    servers."""

    _goals: dict[int, _PendingGoal]
    _goals_of: dict[int, int]
    _goal_by_provider: dict[tuple[int, str], int]
    _goal_by_caller: dict[tuple[int, Any, str], int]
    max_pending_goals_per_client: int
    max_pending_goals: int

    def _goals_refused(self, c: int) -> str | None:
        """Why client ``c`` may not send one more action goal (it, or every client together,
        has as many active as the limit allows), or None."""
        return over_pending_limit(
            "goals",
            "are active",
            self._goals_of.get(c, 0),
            ("MAX_PENDING_GOALS_PER_CLIENT", self.max_pending_goals_per_client),
            len(self._goals),
            ("MAX_PENDING_GOALS", self.max_pending_goals),
        )

    def _cancel_orphaned_goal(self, pending: _PendingGoal) -> None:
        """Tell the action server to stop working on a goal whose client left (the goal is
        already dropped: whatever the server sends for it goes nowhere)."""
        goal = pending.goal
        if goal is not None:
            goal.cancel_requested = True
            if goal.on_cancel is not None:
                with contextlib.suppress(Exception):  # the client is gone: nobody to tell
                    goal.on_cancel(goal)
        elif pending.provider_id is not None and pending.action.provider in self._conns:
            frame = {
                "op": "cancel_action_goal",
                "id": pending.provider_id,
                "action": pending.action.spelled,
            }
            self._send(
                pending.action.provider, dumps(frame), "cancel_action_goal", pending.action.name
            )

    def _action_failure(self, c: int, spelled: str, text: str, msg_id: Any) -> None:
        frame: dict[str, Any] = {
            "op": "action_result",
            "action": spelled,
            "values": text,
            "status": 0,
            "result": False,
        }
        if msg_id is not None:
            frame["id"] = msg_id
        self._send(c, dumps(frame), "action_result", spelled, msg_id)

    def _op_send_action_goal(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "send_action_goal", "action")
        msg_id = obj.get("id")
        feedback = field_of(obj, "send_action_goal", "feedback", bool, False)
        timeout = bounded_timeout(
            field_of(obj, "send_action_goal", "timeout", float, None),
            self.goal_timeout_s,
            "send_action_goal",
        )
        act = self._actions.get(normalize(spelled))
        if act is None:
            self._action_failure(c, spelled, f"Action {spelled} does not exist", msg_id)
            return
        refused = self._goals_refused(c)
        if refused is not None:
            self._action_failure(c, spelled, f"Action {spelled} refused: {refused}", msg_id)
            return
        try:
            if "action_type" in obj:
                given = self.registry.resolve_action(obj["action_type"])
                if given != act.type:
                    raise ConversionError(f"Action {act.name} has type {act.type}, not {given}")
            goal_type = self.registry.action(act.type).goal
            args = obj.get("args", {})
            goal = from_json(self.registry, goal_type, {} if args is None else args, self._now_ns)
        except BAD_INPUT as exc:
            self._action_failure(c, spelled, str(exc), msg_id)
            return
        key = self._next_key
        self._next_key += 1
        pending = _PendingGoal(c, msg_id, spelled, act, feedback, None)
        self._goals[key] = pending
        self._goals_of[c] = self._goals_of.get(c, 0) + 1
        self._goal_by_caller[(c, msg_id, act.name)] = key
        if act.handler is not None:
            handle = ActionGoal(self, key, act.name, act.type, goal, c)
            pending.goal = handle
            try:
                act.handler(handle)
            except Exception as exc:
                self._goal_result(
                    key, f"Action {act.name} handler raised {type(exc).__name__}: {exc}", 0, False
                )
            if key in self._goals:
                self._call_started(key, timeout)
            return
        act.count += 1
        gid = f"action_goal:{act.spelled}:{act.count}"
        pending.provider_id = gid
        self._goal_by_provider[(act.provider, gid)] = key
        frame = {
            "op": "send_action_goal",
            "id": gid,
            "action": act.spelled,
            "action_type": act.type,
            "args": goal,
            "feedback": True,
        }
        self._send(act.provider, dumps(frame), "send_action_goal", act.name, gid)
        self._call_started(key, timeout)

    def _drop_goal(self, key: int) -> _PendingGoal | None:
        pending = self._goals.pop(key, None)
        if pending is not None:
            left = self._goals_of[pending.caller] - 1
            if left:
                self._goals_of[pending.caller] = left
            else:
                del self._goals_of[pending.caller]
            self._call_ended(key)
            self._goal_by_caller.pop((pending.caller, pending.caller_id, pending.action.name), None)
            if pending.provider_id is not None:
                self._goal_by_provider.pop((pending.action.provider, pending.provider_id), None)
            if pending.goal is not None:
                pending.goal.done = True
        return pending

    def _goal_feedback(self, key: int, values: Mapping[str, Any]) -> None:
        pending = self._goals.get(key)
        if pending is None or not pending.feedback:
            return
        fb = from_json(
            self.registry, self.registry.action(pending.action.type).feedback, values, self._now_ns
        )
        frame: dict[str, Any] = {"op": "action_feedback", "action": pending.spelled, "values": fb}
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller, dumps(frame), "action_feedback", pending.action.name, pending.caller_id
        )

    def _goal_result(self, key: int, values: Any, status: int, ok: bool) -> None:
        pending = self._goals.get(key)
        if pending is None:
            return
        if ok:
            values = from_json(
                self.registry,
                self.registry.action(pending.action.type).result,
                values,
                self._now_ns,
            )
        self._drop_goal(key)
        if not ok:
            self._action_failure(pending.caller, pending.spelled, str(values), pending.caller_id)
            return
        frame: dict[str, Any] = {
            "op": "action_result",
            "action": pending.spelled,
            "values": values,
            "status": status,
            "result": True,
        }
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller, dumps(frame), "action_result", pending.action.name, pending.caller_id
        )

    def _op_cancel_action_goal(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "cancel_action_goal", "action")
        key = self._goal_by_caller.get((c, obj.get("id"), normalize(spelled)))
        if key is None:
            raise FrameError(
                f"cancel_action_goal: no active goal with id {obj.get('id')} on {spelled}"
            )
        pending = self._goals[key]
        if pending.goal is not None:
            pending.goal.cancel_requested = True
            if pending.goal.on_cancel is not None:
                pending.goal.on_cancel(pending.goal)
            else:
                pending.goal.finish({}, GOAL_CANCELED)
            return
        frame = {
            "op": "cancel_action_goal",
            "id": pending.provider_id,
            "action": pending.action.spelled,
        }
        self._send(pending.action.provider, dumps(frame), "cancel_action_goal", pending.action.name)

    def _provider_goal(self, c: int, obj: Mapping[str, Any], op: str) -> int:
        spelled = name_field(obj, op, "action")
        gid = field_of(obj, op, "id", str)
        key = self._goal_by_provider.get((c, gid))
        if key is None:
            raise FrameError(f"{op}: unknown goal id {gid} for {spelled}")
        return key

    def _op_action_feedback(self, c: int, obj: Mapping[str, Any]) -> None:
        key = self._provider_goal(c, obj, "action_feedback")
        self._goal_feedback(key, field_of(obj, "action_feedback", "values", dict))

    def _op_action_result(self, c: int, obj: Mapping[str, Any]) -> None:
        key = self._provider_goal(c, obj, "action_result")
        status = field_of(obj, "action_result", "status", int, GOAL_SUCCEEDED)
        result = field_of(obj, "action_result", "result", bool, True)
        values = obj.get("values", {})
        if result:
            if not isinstance(values, dict):
                raise FrameError(
                    f"action_result: Expected field values to be an object, got {kind_of(values)}"
                )
            try:
                self._goal_result(key, values, status, True)
            except ConversionError as exc:
                self._goal_result(key, str(exc), 0, False)
                raise
        else:
            self._goal_result(
                key, values if isinstance(values, str) else dumps(values), status, False
            )

    def _op_advertise_action(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "advertise_action", "action")
        full = self.registry.resolve_action(field_of(obj, "advertise_action", "type", str))
        name = normalize(spelled)
        existing = self._actions.get(name)
        if existing is not None and existing.provider == 0:
            raise FrameError(f"advertise_action: action {name} is provided by the harness")
        self._actions[name] = ActionEntry(name, spelled, full, c, None)

    def _op_unadvertise_action(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "unadvertise_action", "action")
        act = self._actions.get(normalize(spelled))
        if act is None or act.provider != c:
            raise FrameError(
                f"unadvertise_action: action {spelled} is not advertised by this client"
            )
        del self._actions[act.name]

    def advertise_action(
        self,
        action: str,
        type: str,
        handler: Callable[[ActionGoal], None],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Provide ``action`` in-process as ``node``: ``handler(goal)`` starts the goal and
        later calls ``goal.feedback``/``goal.finish``."""
        name = normalize(action)
        self._actions[name] = ActionEntry(
            name, name, self.registry.resolve_action(type), 0, handler, node=node
        )

    def unadvertise_action(self, action: str) -> None:
        """Remove an in-process action server."""
        act = self._actions.get(normalize(action))
        if act is not None and act.provider == 0:
            del self._actions[act.name]
