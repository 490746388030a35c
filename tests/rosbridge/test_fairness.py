"""Bridge fairness (issue 31, breaks 4 and 8), checked on the sans-I/O core: the floor on
``fragment_size``, the caps on pending service calls and action goals, and the per-client send
budget that drops a greedy client's subscription messages while other clients are served."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

from harness.models import load_robot
from harness.recording import Recording
from harness.rosbridge import Bridge, OutgoingFrame, TypeRegistry
from harness.rosbridge.limits import (
    MAX_PENDING_CALLS,
    MAX_PENDING_CALLS_PER_CLIENT,
    MAX_PENDING_GOALS,
    MAX_PENDING_GOALS_PER_CLIENT,
    MIN_FRAGMENT_SIZE,
    SendBudget,
)
from harness.session import Session
from harness.session.bridge import SessionBridge
from harness.session.core import CoreOptions, SessionCore
from harness.session.markers import MARKER_UNBUDGETED, replay_marker
from tests.rosbridge.helpers import install_test_graph
from tests.session.session_helpers import Client

REGISTRY = TypeRegistry()
STRING = "std_msgs/msg/String"
TRIGGER = "std_srvs/srv/Trigger"
FIBONACCI = "example_interfaces/action/Fibonacci"


def send(bridge: Bridge, conn: int, frame: dict[str, Any], now_ns: int = 0) -> list[OutgoingFrame]:
    return bridge.receive(conn, json.dumps(frame), now_ns)


def parsed(outputs: list[OutgoingFrame], conn: int) -> list[dict[str, Any]]:
    return [json.loads(o.data) for o in outputs if o.connection == conn]


WARNINGS = {"op": "set_level", "level": "warning"}
"""What a client sends to be told warnings (the default level is error)."""


# -- fragment_size floor --------------------------------------------------------------------


def test_fragment_size_below_the_minimum_is_raised_with_a_warning() -> None:
    """fragment_size 1 (one frame per character) becomes MIN_FRAGMENT_SIZE, per subscription
    and per connection: a publication costs a bounded number of frames, each told to the
    client in a warning naming the field, the asked and the applied value."""
    bridge = Bridge(REGISTRY, keep_frames=True)
    pub, by_sub, by_conn = bridge.connect(), bridge.connect(), bridge.connect()
    send(bridge, pub, {"op": "advertise", "topic": "/t", "type": STRING})
    send(bridge, by_sub, WARNINGS)
    out = send(bridge, by_sub, {"op": "subscribe", "topic": "/t", "id": "s", "fragment_size": 1})
    assert parsed(out, by_sub) == [
        {
            "op": "status",
            "level": "warning",
            "msg": f"subscribe: fragment_size 1 is below the minimum {MIN_FRAGMENT_SIZE}; "
            f"raised to {MIN_FRAGMENT_SIZE}",
            "id": "s",
        }
    ]
    send(bridge, by_conn, {"op": "set_level", "level": "warning", "fragment_size": 1})
    # (that frame's own warning went out with it; the next op with a small size warns again)
    out = send(bridge, by_conn, {"op": "subscribe", "topic": "/t", "fragment_size": 0})
    assert [f["level"] for f in parsed(out, by_conn)] == ["error"]  # 0 stays an error
    send(bridge, by_conn, {"op": "subscribe", "topic": "/t"})
    bridge.frames()

    text = "x" * 5000
    out = send(bridge, pub, {"op": "publish", "topic": "/t", "msg": {"data": text}})
    whole = '{"op":"publish","topic":"/t","msg":{"data":"' + text + '"}}'
    for conn in (by_sub, by_conn):
        frames = parsed(out, conn)
        assert len(frames) == math.ceil(len(whole) / MIN_FRAGMENT_SIZE)  # not len(whole)
        assert all(f["op"] == "fragment" and len(f["data"]) <= MIN_FRAGMENT_SIZE for f in frames)
        assert "".join(f["data"] for f in frames) == whole
    # what was recorded is what was sent
    assert [t.data for t in bridge.frames()[1:]] == [o.data for o in out]


def test_connection_fragment_size_warning_names_the_op() -> None:
    bridge = Bridge(REGISTRY)
    c = bridge.connect()
    send(bridge, c, WARNINGS)
    out = send(bridge, c, {"op": "set_level", "level": "warning", "fragment_size": 10})
    assert parsed(out, c) == [
        {
            "op": "status",
            "level": "warning",
            "msg": f"set_level: fragment_size 10 is below the minimum {MIN_FRAGMENT_SIZE}; "
            f"raised to {MIN_FRAGMENT_SIZE}",
        }
    ]
    # at or above the floor: applied as asked, without a word
    assert send(bridge, c, {"op": "set_level", "level": "warning", "fragment_size": 2000}) == []


# -- pending service calls ------------------------------------------------------------------


def _provider(bridge: Bridge) -> int:
    provider = bridge.connect()
    send(bridge, provider, {"op": "advertise_service", "service": "/never", "type": TRIGGER})
    return provider


def _call(bridge: Bridge, conn: int, n: int) -> list[OutgoingFrame]:
    return send(bridge, conn, {"op": "call_service", "service": "/never", "id": f"c{n}"})


def test_pending_calls_are_capped_per_client() -> None:
    """A client's calls to a provider that never answers: the first
    MAX_PENDING_CALLS_PER_CLIENT reach the provider, the next is answered at once with a
    failed service_response naming the limit; an answer frees room for one more; the bridge
    holds no more than the cap."""
    bridge = Bridge(REGISTRY)
    provider, caller = _provider(bridge), bridge.connect()
    for n in range(MAX_PENDING_CALLS_PER_CLIENT):
        out = _call(bridge, caller, n)
        assert [(o.connection, o.op) for o in out] == [(provider, "call_service")]
    refused = _call(bridge, caller, -1)
    assert parsed(refused, caller) == [
        {
            "op": "service_response",
            "service": "/never",
            "values": f"Service /never refused: {MAX_PENDING_CALLS_PER_CLIENT} calls of this "
            f"client are pending, the limit per client (MAX_PENDING_CALLS_PER_CLIENT "
            f"{MAX_PENDING_CALLS_PER_CLIENT})",
            "result": False,
            "id": "c-1",
        }
    ]
    assert parsed(refused, provider) == []
    assert len(bridge._calls) == MAX_PENDING_CALLS_PER_CLIENT
    # another client is not refused for this one's calls
    other = bridge.connect()
    assert [o.connection for o in _call(bridge, other, 0)] == [provider]
    # one answered: room for exactly one more
    done = send(
        bridge,
        provider,
        {
            "op": "service_response",
            "service": "/never",
            "id": "service_request:/never:1",
            "values": {"success": True, "message": ""},
            "result": True,
        },
    )
    assert parsed(done, caller)[0]["result"] is True
    assert [o.connection for o in _call(bridge, caller, 10**6)] == [provider]
    assert parsed(_call(bridge, caller, 10**6 + 1), caller)[0]["result"] is False
    # the counts follow the calls away: a caller that leaves frees its share
    bridge.disconnect(caller)
    assert len(bridge._calls) == 1
    assert bridge._calls_of == {other: 1}


def test_pending_calls_are_capped_in_total() -> None:
    bridge = Bridge(REGISTRY)
    _provider(bridge)
    clients = MAX_PENDING_CALLS // MAX_PENDING_CALLS_PER_CLIENT
    for _ in range(clients):
        caller = bridge.connect()
        for n in range(MAX_PENDING_CALLS_PER_CLIENT):
            _call(bridge, caller, n)
    assert len(bridge._calls) == MAX_PENDING_CALLS
    late = bridge.connect()
    refused = parsed(_call(bridge, late, 0), late)
    assert refused[0]["result"] is False
    assert refused[0]["values"] == (
        f"Service /never refused: {MAX_PENDING_CALLS} calls are pending, the limit for all "
        f"clients together (MAX_PENDING_CALLS {MAX_PENDING_CALLS})"
    )
    assert len(bridge._calls) == MAX_PENDING_CALLS


# -- pending action goals -------------------------------------------------------------------


def _goal(bridge: Bridge, conn: int, n: int) -> list[OutgoingFrame]:
    frame = {"op": "send_action_goal", "action": "/fib", "args": {"order": 1}, "id": f"g{n}"}
    return send(bridge, conn, frame)


def test_pending_goals_are_capped_per_client_and_in_total() -> None:
    bridge = Bridge(REGISTRY)
    server = bridge.connect()
    send(bridge, server, {"op": "advertise_action", "action": "/fib", "type": FIBONACCI})
    first = bridge.connect()
    for n in range(MAX_PENDING_GOALS_PER_CLIENT):
        assert [o.connection for o in _goal(bridge, first, n)] == [server]
    refused = parsed(_goal(bridge, first, -1), first)
    assert refused == [
        {
            "op": "action_result",
            "action": "/fib",
            "values": f"Action /fib refused: {MAX_PENDING_GOALS_PER_CLIENT} goals of this "
            f"client are active, the limit per client (MAX_PENDING_GOALS_PER_CLIENT "
            f"{MAX_PENDING_GOALS_PER_CLIENT})",
            "status": 0,
            "result": False,
            "id": "g-1",
        }
    ]
    for _ in range(MAX_PENDING_GOALS // MAX_PENDING_GOALS_PER_CLIENT - 1):
        client = bridge.connect()
        for n in range(MAX_PENDING_GOALS_PER_CLIENT):
            _goal(bridge, client, n)
    assert len(bridge._goals) == MAX_PENDING_GOALS
    late = bridge.connect()
    assert parsed(_goal(bridge, late, 0), late)[0]["values"] == (
        f"Action /fib refused: {MAX_PENDING_GOALS} goals are active, the limit for all "
        f"clients together (MAX_PENDING_GOALS {MAX_PENDING_GOALS})"
    )
    # a finished goal frees room
    send(
        bridge,
        server,
        {"op": "action_result", "action": "/fib", "id": "action_goal:/fib:1", "values": {}},
    )
    assert [o.connection for o in _goal(bridge, late, 1)] == [server]
    bridge.disconnect(first)
    assert first not in bridge._goals_of


# -- send budget ----------------------------------------------------------------------------

STEP_NS = 2_000_000
DROPPED = re.compile(
    r"dropped (\d+) messages on /big: this client is over its send budget of 5000 frames or "
    r"64 MiB per second of simulation time \(subscribe with throttle_rate or to fewer topics\)"
)


def _greedy_setup(bridge: Bridge) -> tuple[int, int]:
    """A greedy client subscribed to /big (with the smallest fragments it may have) and a
    polite one that only calls services."""
    install_test_graph(bridge)
    bridge.advertise("/big", STRING)
    greedy, polite = bridge.connect(), bridge.connect()
    send(bridge, greedy, WARNINGS)
    send(bridge, greedy, {"op": "subscribe", "topic": "/big", "fragment_size": 1})
    bridge.drain()
    return greedy, polite


def _run_steps(bridge: Bridge, greedy: int, polite: int, steps: int) -> list[OutgoingFrame]:
    """Per step: a 100 kB message on /big, then the polite client's service call; returns
    every output."""
    outputs: list[OutgoingFrame] = []
    for k in range(1, steps + 1):
        now = k * STEP_NS
        bridge.publish("/big", STRING, {"data": "x" * 100_000}, now)
        outputs += bridge.drain()
        call = {"op": "call_service", "service": "/add_two_ints", "args": {"a": k, "b": 1}}
        answer = send(bridge, polite, {**call, "id": k}, now)
        # the polite client is answered in the same step, whatever the greedy one costs
        assert parsed(answer, polite) == [
            {
                "op": "service_response",
                "service": "/add_two_ints",
                "values": {"sum": k + 1},
                "result": True,
                "id": k,
            }
        ]
        outputs += answer
    return outputs


def test_a_client_over_its_send_budget_is_throttled_not_waited_for() -> None:
    """100 kB per 2 ms step in 1 KiB fragments is ~50,000 frames/s: a client with a budget of
    5,000 frames/s is sent what its budget allows (messages beyond it dropped whole, before
    any frame is made), told so once per second, and the frames sent are the frames
    recorded; another client's service calls are answered in the same step throughout."""
    budget = SendBudget()
    bridge = Bridge(REGISTRY, keep_frames=True, send_budget=budget)
    greedy, polite = _greedy_setup(bridge)
    bridge.frames()
    steps = 1000  # 2 s of simulation time
    outputs = _run_steps(bridge, greedy, polite, steps)
    to_greedy = [o for o in outputs if o.connection == greedy]
    fragments = [o for o in to_greedy if o.op == "fragment"]
    per_message = math.ceil((len('{"op":"publish","topic":"/big","msg":{"data":""}}') + 100_000)
                            / MIN_FRAGMENT_SIZE)  # fmt: skip
    sent_messages = len(fragments) // per_message
    assert len(fragments) == sent_messages * per_message  # whole messages or nothing
    # what the budget allows over 2 s (plus its burst and one message of overshoot)
    spent = budget.cost_ns(len(to_greedy), sum(len(o.data) for o in to_greedy))
    assert spent <= steps * STEP_NS + budget.burst_ns + budget.cost_ns(per_message, 101_000)
    assert sent_messages < steps // 4  # most were dropped ...
    assert sent_messages > 0  # ... not all
    assert bridge.throttled(greedy) == {"/big": steps - sent_messages}
    assert bridge.throttled(polite) == {}
    statuses = [json.loads(o.data) for o in to_greedy if o.op == "status"]
    assert len(statuses) == 2  # at most one per second of the bridge's clock
    told = [DROPPED.fullmatch(s["msg"]) for s in statuses]
    assert all(s["level"] == "warning" for s in statuses)
    assert all(told), statuses
    # the server's text for drops (a slow reader's): what a client counts drops by
    assert sum(int(m.group(1)) for m in told if m) <= steps - sent_messages
    # the recording holds exactly what was sent, nothing of what was dropped
    out_taps = [t for t in bridge.frames() if t.direction == 1]
    assert [(t.connection, t.data) for t in out_taps] == [(o.connection, o.data) for o in outputs]


def test_without_a_budget_every_message_is_sent() -> None:
    """The same load on a bridge without a budget (a standalone server's default): nothing
    is dropped; the drops above are the budget's doing."""
    bridge = Bridge(REGISTRY)
    greedy, polite = _greedy_setup(bridge)
    outputs = _run_steps(bridge, greedy, polite, 50)
    assert len([o for o in outputs if o.connection == greedy]) == 50 * 98
    assert bridge.throttled(greedy) == {}


def test_the_budget_refills_with_the_bridge_clock() -> None:
    """After a pause longer than the burst, a throttled client is sent messages again."""
    budget = SendBudget(frames_per_s=1000, bytes_per_s=2**30, burst_s=0.01)
    bridge = Bridge(REGISTRY, send_budget=budget)
    bridge.advertise("/t", STRING)
    c = bridge.connect()
    send(bridge, c, {"op": "subscribe", "topic": "/t"})

    def sent_at(now: int) -> bool:
        bridge.publish("/t", STRING, {"data": "hi"}, now)
        return any(o.connection == c and o.op == "publish" for o in bridge.drain())

    # 1000 frames/s: a frame costs 1 ms (and its bytes a few ns); 10 ms of burst: at t = 0,
    # 10 are sent (the budget is then spent to just past 0), the rest dropped
    assert [sent_at(0) for _ in range(15)] == [True] * 10 + [False] * 5
    assert not sent_at(100)  # 100 ns later: still spent
    assert sent_at(1_000_000)  # the clock caught up: sent again
    assert not sent_at(1_000_000)  # ... and that one spent the next millisecond
    # the clock going back (a new epoch) takes the debt back with it, not 1 ms more of it
    assert not sent_at(0)
    assert sent_at(500)
    assert bridge.throttled(c) == {"/t": 8}


def test_session_bridge_budget_is_on_and_replays_the_same() -> None:
    """A session's bridge has a send budget by default, on simulation time: the same frames
    at the same simulation times drop the same messages (a replay records what the live run
    sent)."""

    def run() -> list[tuple[int, str | bytes]]:
        clock = [0]
        bridge = SessionBridge(lambda: clock[0], keep_frames=True)
        assert bridge.send_budget == SendBudget()
        bridge.advertise("/big", STRING)
        c = bridge.connect()
        send(bridge, c, {"op": "subscribe", "topic": "/big", "fragment_size": 1})
        for k in range(200):
            clock[0] = k * STEP_NS
            bridge.publish("/big", STRING, {"data": "y" * 200_000}, clock[0])
        assert bridge.throttled(c)
        return [(t.connection, t.data) for t in bridge.frames()]

    assert run() == run()


@pytest.mark.parametrize(
    "kwargs", [{"frames_per_s": 0}, {"bytes_per_s": -1}, {"burst_s": float("nan")}]
)
def test_send_budget_refuses_nonsense(kwargs: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match="SendBudget: frames_per_s and bytes_per_s"):
        SendBudget(**kwargs)


# -- live: a real session over a real socket, recorded -------------------------------------


def test_live_session_raises_fragment_size_and_records_what_it_sent(tmp_path: Path) -> None:
    """A lockstep demo session with a client asking for fragment_size 1 on /tf:
    the client is warned, each message reaches it in ceil(len / MIN_FRAGMENT_SIZE) fragments
    (not one per character), and the recording holds exactly the frames the client got."""
    path = tmp_path / "fair.mcap"
    with Session("demo", record_to=path) as session:
        client = Client(session.url)
        try:
            client.send(WARNINGS)
            client.send(
                {
                    "op": "subscribe",
                    "topic": "/tf",
                    "type": "tf2_msgs/msg/TFMessage",
                    "fragment_size": 1,
                }
            )
            client.step(50)  # /tf at 100 Hz, 2 ms steps: 10 messages of ~2 kB
        finally:
            client.close()
    got = client.received
    assert got[0]["op"] == "status"
    assert got[0]["msg"] == (
        f"subscribe: fragment_size 1 is below the minimum {MIN_FRAGMENT_SIZE}; "
        f"raised to {MIN_FRAGMENT_SIZE}"
    )
    fragments = [f for f in got if f["op"] == "fragment"]
    messages: dict[str, list[dict[str, Any]]] = {}
    for f in fragments:
        messages.setdefault(f["id"], []).append(f)
    assert len(messages) == 10
    for parts in messages.values():
        whole = "".join(p["data"] for p in parts)
        assert json.loads(whole)["topic"] == "/tf"
        assert len(whole) > MIN_FRAGMENT_SIZE
        assert len(parts) == math.ceil(len(whole) / MIN_FRAGMENT_SIZE)
    with Recording(path) as recording:
        out = [
            json.loads(f.text)
            for f in recording.bridge_frames()
            if f.direction == 1 and f.connection == 1
        ]
    assert out == got


def test_the_harness_own_link_is_exempt_and_a_replay_exempts_it_too() -> None:
    """A client-mode session's connection to the external server carries every external
    client's traffic: it is exempt from the send budget, recorded as a
    ``harness/unbudgeted`` marker before anything is sent on it, and a replay applying that
    marker exempts the same connection (so a full-level replay sends what the run sent)."""
    clock = [0]
    live = SessionBridge(lambda: clock[0], keep_frames=True)
    live.advertise("/big", STRING)
    link, client = live.connect(), live.connect()
    live.exempt_from_budget(link)
    for c in (link, client):
        send(live, c, {"op": "subscribe", "topic": "/big", "fragment_size": 1})
    for k in range(100):
        clock[0] = k * STEP_NS
        live.publish("/big", STRING, {"data": "y" * 100_000}, clock[0])
    assert live.throttled(link) == {}
    assert live.throttled(client)["/big"] > 50
    taps = live.frames()
    markers = [t for t in taps if t.name == MARKER_UNBUDGETED]
    assert [(t.connection, t.direction, t.op, json.loads(t.data)) for t in markers] == [
        (0, 0, "", {"connection": link})
    ]
    assert taps.index(markers[0]) < min(i for i, t in enumerate(taps) if t.connection == link)

    core = SessionCore(load_robot("demo"), CoreOptions(joint_states_hz=0, tf_hz=0, clock_hz=0))
    assert core.bridge is not None
    replay_marker(core, MARKER_UNBUDGETED, markers[0].data)
    assert core.bridge.connections == [1]
    assert core.bridge._conns[link].budget is None
    assert core.bridge._conns[link].id == link


def test_answers_are_not_charged() -> None:
    """A lockstep client stepping a 10 kHz simulation one step per call gets 10,000 answers
    per simulated second, twice its frame budget: answers come one per frame it sends (paced
    by the session), so they are not charged and its 1 kHz subscription still flows."""
    bridge = Bridge(REGISTRY, send_budget=SendBudget())
    install_test_graph(bridge)
    bridge.advertise("/t", STRING)
    c = bridge.connect()
    send(bridge, c, {"op": "subscribe", "topic": "/t"})
    published = 0
    for k in range(10_000):  # one simulated second of 100 us steps
        now = k * 100_000
        call = {"op": "call_service", "service": "/add_two_ints", "args": {"a": k, "b": 0}}
        assert parsed(send(bridge, c, {**call, "id": k}, now), c)[0]["result"] is True
        if k % 10 == 0:
            bridge.publish("/t", STRING, {"data": "hi"}, now)
            published += len(bridge.drain())
    assert published == 1000
    assert bridge.throttled(c) == {}
