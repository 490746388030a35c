"""Services on the bridge: calls routed to a client's or an in-process service, answers,
timeouts and failures (a room of :class:`~harness.rosbridge.Bridge`, mixed into it)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Final

from harness.rosbridge.convert import dumps, from_json
from harness.rosbridge.deadlines import MAX_TIMEOUT_S, bounded_timeout
from harness.rosbridge.errors import ConversionError, FrameError
from harness.rosbridge.frames import BridgeHost, field_of, name_field
from harness.rosbridge.graph import HARNESS_NODE, ServiceEntry, normalize
from harness.rosbridge.limits import over_pending_limit

__all__ = ["DEFERRED", "ServiceCall", "ServiceOps"]


class _Deferred:
    def __repr__(self) -> str:
        return "DEFERRED"


DEFERRED: Final = _Deferred()
"""Returned by a service handler that will answer later through its :class:`ServiceCall`."""


class ServiceCall:
    """One call of an in-process service. The handler returns the response values, or
    :data:`DEFERRED` and later calls :meth:`respond` or :meth:`fail` exactly once."""

    def __init__(
        self,
        bridge: ServiceOps,
        key: int,
        service: str,
        type: str,
        args: dict[str, Any],
        connection: int,
    ) -> None:
        self._bridge = bridge
        self.key = key
        self.service = service
        self.type = type
        self.args = args
        self.connection = connection
        self.done = False

    def respond(self, values: Mapping[str, Any]) -> None:
        """Answer the call with ``values`` (validated against the response type)."""
        self._bridge._finish_call(self.key, True, values)

    def fail(self, message: str) -> None:
        """Answer the call with ``result: false`` and ``message``."""
        self._bridge._finish_call(self.key, False, message)


@dataclass(slots=True)
class _PendingCall:
    caller: int
    caller_id: Any
    spelled: str
    service: ServiceEntry
    provider_id: str | None
    callback: Callable[[bool, Any], None] | None = None
    call: ServiceCall | None = None
    timed: bool = False
    """Whether its deadline was started (an in-process handler answering at once has none)."""


class ServiceOps(BridgeHost):
    """The service ops (``call_service``, ``service_response``, ``advertise_service``,
    ``unadvertise_service``) and in-process services."""

    _calls: dict[int, _PendingCall]
    _calls_of: dict[int, int]
    _call_by_provider: dict[tuple[int, str], int]
    max_pending_calls_per_client: int
    max_pending_calls: int

    def _calls_refused(self, c: int) -> str | None:
        """Why client ``c`` may not start one more service call (it, or every client
        together, has as many pending as the limit allows), or None."""
        return over_pending_limit(
            "calls",
            "are pending",
            self._calls_of.get(c, 0),
            ("MAX_PENDING_CALLS_PER_CLIENT", self.max_pending_calls_per_client),
            len(self._calls),
            ("MAX_PENDING_CALLS", self.max_pending_calls),
        )

    def _service_failure(self, c: int, spelled: str, values: Any, msg_id: Any) -> None:
        frame: dict[str, Any] = {
            "op": "service_response",
            "service": spelled,
            "values": values,
            "result": False,
        }
        if msg_id is not None:
            frame["id"] = msg_id
        self._send(c, dumps(frame), "service_response", spelled, msg_id)

    def _op_call_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "call_service", "service")
        msg_id = obj.get("id")
        args = obj.get("args", {})
        timeout = self.call_timeout_s
        if "timeout" in obj or type(timeout) is not float or not 0 <= timeout <= MAX_TIMEOUT_S:
            # (a default that is a float in range is its own bounded timeout)
            timeout = bounded_timeout(
                field_of(obj, "call_service", "timeout", float, None),
                self.call_timeout_s,
                "call_service",
            )
        # keys are normalized names: a name found as given needs no normalizing
        svc = self._services.get(spelled) or self._services.get(normalize(spelled))
        if svc is None:
            self._service_failure(c, spelled, f"Service {spelled} does not exist", msg_id)
            return
        refused = self._calls_refused(c)
        if refused is not None:
            self._service_failure(c, spelled, f"Service {spelled} refused: {refused}", msg_id)
            return
        request_type = self.registry.service(svc.type).request
        try:
            if args is None:
                args = {}
            if isinstance(args, list):
                names = [f.name for f in self.registry.message(request_type).fields]
                if len(args) > len(names):
                    raise ConversionError(
                        f"{request_type} has {len(names)} fields, "
                        f"but {len(args)} positional args were given"
                    )
                args = dict(zip(names, args, strict=False))
            request = from_json(self.registry, request_type, args, self._now_ns)
        except ConversionError as exc:
            self._service_failure(c, spelled, str(exc), msg_id)
            return
        self._start_call(svc, c, msg_id, spelled, request, timeout)

    def _start_call(
        self,
        svc: ServiceEntry,
        caller: int,
        caller_id: Any,
        spelled: str,
        request: dict[str, Any],
        timeout: float | None,
        callback: Callable[[bool, Any], None] | None = None,
    ) -> None:
        key = self._next_key
        self._next_key += 1
        pending = _PendingCall(caller, caller_id, spelled, svc, None, callback)
        self._calls[key] = pending
        if caller:
            self._calls_of[caller] = self._calls_of.get(caller, 0) + 1
        if svc.handler is not None:
            call = ServiceCall(self, key, svc.name, svc.type, request, caller)
            pending.call = call
            try:
                result = svc.handler(call)
            except Exception as exc:  # a failing handler answers, it does not kill the bridge
                self._finish_call(
                    key, False, f"Service {svc.name} handler raised {type(exc).__name__}: {exc}"
                )
                return
            if result is DEFERRED:
                if not call.done:
                    pending.timed = True
                    self._call_started(key, self.call_timeout_s if timeout is None else timeout)
                return
            if not call.done:
                if isinstance(result, Mapping):
                    call.respond(result)
                else:
                    call.fail(
                        f"Service {svc.name} handler returned {type(result).__name__}, "
                        "not a dict or DEFERRED"
                    )
            return
        svc.count += 1
        rid = f"service_request:{svc.spelled}:{svc.count}"
        pending.provider_id = rid
        self._call_by_provider[(svc.provider, rid)] = key
        frame = {"op": "call_service", "id": rid, "service": svc.spelled, "args": request}
        self._send(svc.provider, dumps(frame), "call_service", svc.name, rid)
        pending.timed = True
        self._call_started(key, self.call_timeout_s if timeout is None else timeout)

    def _drop_call(self, key: int) -> _PendingCall | None:
        pending = self._calls.pop(key, None)
        if pending is not None and pending.caller:
            left = self._calls_of[pending.caller] - 1
            if left:
                self._calls_of[pending.caller] = left
            else:
                del self._calls_of[pending.caller]
        if pending is not None and pending.timed:  # answered at once: no deadline started
            self._call_ended(key)
        if pending is not None and pending.provider_id is not None:
            self._call_by_provider.pop((pending.service.provider, pending.provider_id), None)
        if pending is not None and pending.call is not None:
            pending.call.done = True
        return pending

    def _finish_call(self, key: int, ok: bool, values: Any) -> None:
        pending = self._calls.get(key)
        if pending is None:
            return
        if ok:
            response_type = self.registry.service(pending.service.type).response
            try:
                values = from_json(self.registry, response_type, values, self._now_ns)
            except ConversionError as exc:
                ok, values = False, str(exc)
                if pending.service.handler is None:
                    self.status(
                        pending.service.provider,
                        "error",
                        f"service_response: {exc}",
                        pending.provider_id,
                    )
        self._drop_call(key)
        if pending.callback is not None:
            pending.callback(ok, values)
            return
        if not ok:
            self._service_failure(
                pending.caller,
                pending.spelled,
                values if isinstance(values, (str, dict)) else str(values),
                pending.caller_id,
            )
            return
        frame: dict[str, Any] = {
            "op": "service_response",
            "service": pending.spelled,
            "values": values,
            "result": True,
        }
        if pending.caller_id is not None:
            frame["id"] = pending.caller_id
        self._send(
            pending.caller,
            dumps(frame),
            "service_response",
            pending.service.name,
            pending.caller_id,
        )

    def _op_service_response(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "service_response", "service")
        rid = field_of(obj, "service_response", "id", str)
        result = field_of(obj, "service_response", "result", bool, True)
        key = self._call_by_provider.get((c, rid))
        if key is None:
            raise FrameError(f"service_response: unknown service request id {rid} for {spelled}")
        values = obj.get("values", {})
        if result:
            if values is None:
                values = {}
            self._finish_call(key, True, values)
        else:
            self._finish_call(
                key, False, values if isinstance(values, (str, dict)) else dumps(values)
            )

    def _op_advertise_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "advertise_service", "service")
        full = self.registry.resolve_service(field_of(obj, "advertise_service", "type", str))
        name = normalize(spelled)
        existing = self._services.get(name)
        if existing is not None and existing.provider == 0:
            raise FrameError(f"advertise_service: service {name} is provided by the harness")
        if existing is not None and existing.provider != c:
            self.status(
                c,
                "warning",
                f"advertise_service: service {name} taken over from another client",
                obj.get("id"),
            )
        self._services[name] = ServiceEntry(name, spelled, full, c, None)

    def _op_unadvertise_service(self, c: int, obj: Mapping[str, Any]) -> None:
        spelled = name_field(obj, "unadvertise_service", "service")
        svc = self._services.get(normalize(spelled))
        if svc is None or svc.provider != c:
            raise FrameError(
                f"unadvertise_service: service {spelled} is not advertised by this client"
            )
        del self._services[svc.name]

    def advertise_service(
        self,
        service: str,
        type: str,
        handler: Callable[[ServiceCall], Any],
        *,
        node: str = HARNESS_NODE,
    ) -> None:
        """Provide ``service`` in-process as ``node``: ``handler(call)`` returns the response
        values or :data:`DEFERRED` (then answers later with ``call.respond``/``call.fail``)."""
        name = normalize(service)
        self._services[name] = ServiceEntry(
            name, name, self.registry.resolve_service(type), 0, handler, node=node
        )

    def unadvertise_service(self, service: str) -> None:
        """Remove an in-process service."""
        svc = self._services.get(normalize(service))
        if svc is not None and svc.provider == 0:
            del self._services[svc.name]

    def call_service(
        self,
        service: str,
        args: Mapping[str, Any],
        callback: Callable[[bool, Any], None],
        now_ns: int,
        timeout: float | None = None,
    ) -> None:
        """Call any service in-process; ``callback(ok, values_or_error_text)`` runs when it
        answers (maybe immediately)."""
        self._now_ns = now_ns
        svc = self._services.get(normalize(service))
        if svc is None:
            callback(False, f"Service {service} does not exist")
            return
        request = from_json(self.registry, self.registry.service(svc.type).request, args, now_ns)
        self._start_call(svc, 0, None, service, request, timeout, callback)
