"""Frame fields and per-connection state shared by the rosbridge protocol's rooms
(:mod:`~harness.rosbridge.protocol`, :mod:`~harness.rosbridge.topics`,
:mod:`~harness.rosbridge.services`, :mod:`~harness.rosbridge.actions`,
:mod:`~harness.rosbridge.outgoing`): typed field access with rosbridge's error texts, the
``status`` levels, and :class:`BridgeHost`, what a room needs of the bridge it is part of."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Final, NamedTuple

from harness.names import name_problem
from harness.rosbridge.errors import ConversionError, FrameError, TypeNameError, UnknownTypeError
from harness.rosbridge.graph import ActionEntry, ServiceEntry
from harness.rosbridge.limits import SendBudget
from harness.rosbridge.types import TypeRegistry

__all__ = [
    "BAD_INPUT",
    "LEVELS",
    "BridgeHost",
    "Connection",
    "Deadline",
    "field_of",
    "kind_of",
    "name_field",
]

LEVELS: Final = {"info": 0, "warning": 1, "error": 2, "none": 3}
BAD_INPUT = (FrameError, ConversionError, TypeNameError, UnknownTypeError)
"""What a malformed frame raises (answered with a ``status`` error, never fatal)."""


def kind_of(value: object) -> str:
    """How rosbridge names a JSON value's type in its error texts ("an int", "null"...)."""
    if isinstance(value, bool):
        return "a bool"
    return {
        int: "an int",
        float: "a float",
        str: "a string",
        list: "a list",
        dict: "an object",
    }.get(type(value), "null")


_EXPECT = {str: "a string", bool: "a bool", int: "an int", float: "a number", dict: "an object"}


def field_of(obj: Mapping[str, Any], op: str, key: str, kind: type, default: Any = ...) -> Any:
    """A typed field of an op; missing or wrong-typed raises :class:`FrameError`."""
    if key not in obj:
        if default is ...:
            raise FrameError(f"{op}: Expected a {key} field but none was found.")
        return default
    value = obj[key]
    ok = isinstance(value, kind) and not (kind in (int, float) and isinstance(value, bool))
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        ok = True
    if not ok:
        raise FrameError(
            f"{op}: Expected field {key} to be {_EXPECT[kind]}, got {kind_of(value)} "
            f"({json.dumps(value)[:40]})"
        )
    return value


def name_field(obj: Mapping[str, Any], op: str, key: str) -> str:
    """A ROS name field of an op (missing, wrong-typed or invalid raises FrameError)."""
    value: str = obj.get(key)  # type: ignore[assignment]  # checked next
    if type(value) is str and value in _VALID_NAMES:
        return value
    value = field_of(obj, op, key, str)
    problem = name_problem(value, "topic")  # topics, services and actions: one rule set
    if problem is not None:
        raise FrameError(f"{op}: Invalid {key} name {value!r}: it {problem}")
    if len(_VALID_NAMES) < _VALID_NAMES_MAX:
        _VALID_NAMES.add(value)
    return value


_VALID_NAMES: set[str] = set()
"""Names :func:`name_field` found valid (a client names the same few every frame)."""
_VALID_NAMES_MAX = 4096


@dataclass
class Connection:
    """One connection's protocol state: its ``set_level``, fragmentation, the fragmented
    messages it is sending, and its send budget (:mod:`harness.rosbridge.budget`): until when
    its budget is spent, and the subscription messages it was not sent, by topic."""

    id: int
    peer: str
    level: int = LEVELS["error"]
    fragment_size: int | None = None
    fragments: dict[Any, tuple[int, dict[int, str]]] = field(default_factory=dict)
    fragment_bytes: int = 0
    fragment_count: int = 0
    budget: SendBudget | None = None
    spent_until_ns: int | None = None
    budget_now_ns: int = 0
    throttled: dict[str, int] = field(default_factory=dict)
    unreported: dict[str, int] = field(default_factory=dict)
    report_after_ns: int | None = None


class Deadline(NamedTuple):
    """A service call or action goal whose answer has a deadline: started (``timeout_s``
    from now, on the owner's clock: it calls :meth:`~harness.rosbridge.Bridge.time_out_call`
    with ``key`` then) or ended (``timeout_s`` None: answered or gone)."""

    key: int
    timeout_s: float | None


class BridgeHost:
    """What the bridge's rooms (services, actions) use of the :class:`~harness.rosbridge.Bridge`
    they are mixed into: declared here for the type checker, defined by the bridge."""

    registry: TypeRegistry
    call_timeout_s: float
    goal_timeout_s: float
    _deadline_log: list[Deadline] | None
    _conns: dict[int, Connection]
    _services: dict[str, ServiceEntry]
    _actions: dict[str, ActionEntry]
    _next_key: int
    _now_ns: int

    def deadlines(self) -> list[Deadline]:
        """The deadlines started and ended since the last call, in order (drained, as
        :meth:`~harness.rosbridge.Bridge.drain` drains frames). Kept from the first call on:
        an owner that enforces deadlines calls it once before any call can start."""
        log = self._deadline_log
        self._deadline_log = []
        return [] if log is None else log

    def _call_started(self, key: int, timeout_s: float) -> None:
        if self._deadline_log is not None:
            self._deadline_log.append(Deadline(key, timeout_s))

    def _call_ended(self, key: int) -> None:
        if self._deadline_log is not None:
            self._deadline_log.append(Deadline(key, None))

    if TYPE_CHECKING:

        def _send(
            self,
            connection: int,
            text: str,
            op: str,
            name: str,
            frag_id: Any = None,
            fragment_size: int | None = None,
            queue_limit: int = 0,
        ) -> None: ...

        def status(self, connection: int, level: str, msg: str, id: Any = None) -> None: ...

        @staticmethod
        def _split(text: str) -> tuple[list[Any], str | None]: ...

        def _process(self, connection: int, obj: Any) -> None: ...
