"""``/harness/step`` requests, including the batched form: step until a topic has published.

A lockstep client that waits for the simulation's next message (a camera frame, a joint state
at 100 Hz) would otherwise call ``/harness/step`` once per step and look at what arrived. One
request can instead say ``{"steps": 100, "until_topic": "/joint_states", "until_count": 1}``:
the session steps until ``/joint_states`` has been published once more, at most 100 steps,
and answers with the simulation time it stopped at. ``{"steps": n}`` alone is the old form
(the answer is unchanged: the response type gained no field, so old clients see no change).

A step request can also carry the command it steps with: rosbridge v2 lets one WebSocket
message hold several JSON objects, processed in order, so
``{"op": "publish", ...}{"op": "call_service", "service": "/harness/step", ...}`` in one
message applies the command and then steps, exactly as the two messages sent one after the
other would (recorded as one incoming frame), for one message per step instead of two.

Counted are the messages the session publishes on its own topics (joint states, clock, tf,
sensors) whether or not anyone subscribes; a topic only clients publish never counts during a
call (client frames are handled between calls), so such a request takes ``steps`` steps.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from harness.session.errors import SessionError

__all__ = ["PublishCounter", "StepRequest", "parse_step_request", "run_step"]


@dataclass(frozen=True)
class StepRequest:
    """One ``/harness/step`` request: at most ``steps`` steps; with ``until_topic``, stop once
    it has been published ``until_count`` times since the request began."""

    steps: int
    until_topic: str = ""
    until_count: int = 1


class PublishCounter:
    """How many messages the session has published on each topic (its own publications)."""

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}

    def note(self, topic: str) -> None:
        """Count one message published on ``topic``."""
        self._counts[topic] = self._counts.get(topic, 0) + 1

    def count(self, topic: str) -> int:
        """Messages published on ``topic`` so far."""
        return self._counts.get(topic, 0)


def parse_step_request(request: Mapping[str, Any], max_steps: int) -> StepRequest:
    """The request as a :class:`StepRequest`; a clear :class:`SessionError` when it is wrong."""
    steps = int(request.get("steps") or 0)
    if steps > max_steps:
        raise SessionError(
            f"{steps} steps requested, more than max_step_request={max_steps} per call: "
            "nothing stepped; ask in several calls"
        )
    topic = str(request.get("until_topic") or "")
    count = int(request.get("until_count") or 0)
    if count and not topic:
        raise SessionError(
            f"/harness/step: until_count={count} needs an until_topic: nothing stepped"
        )
    if topic and not topic.startswith("/"):
        raise SessionError(
            f"/harness/step: until_topic {topic!r} must be an absolute topic name (start "
            "with '/'): nothing stepped"
        )
    return StepRequest(steps, topic, count or 1)


def run_step(request: StepRequest, advance: Callable[[], None], published: PublishCounter) -> int:
    """Take the steps ``request`` asks for with ``advance``; the number taken."""
    if not request.until_topic:
        for _ in range(request.steps):
            advance()
        return request.steps
    goal = published.count(request.until_topic) + request.until_count
    done = 0
    while done < request.steps and published.count(request.until_topic) < goal:
        advance()
        done += 1
    return done
