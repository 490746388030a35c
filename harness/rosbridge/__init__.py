"""The rosbridge v2 layer: a sans-I/O protocol core, the asyncio WebSocket server, rosapi,
ROS 2 message validation and a client for external rosbridge servers. Knows nothing of MuJoCo.

- :class:`Bridge` (``protocol.py``): the shared graph and per-connection state;
  ``receive(connection, frame, now_ns) -> list[OutgoingFrame]`` (frame parsing, the op table);
  in-process publishers, subscribers, service and action servers; the frames it saw
  (``frames()``).
- its rooms: ``topics.py``, ``services.py``, ``actions.py``, ``fragments.py``, ``budget.py``
  (ops of those concerns, per-client send budgets: mixed into :class:`Bridge`),
  ``outgoing.py`` (every frame out: :class:`OutgoingFrame`, :class:`TapRecord`, numbering,
  fragmenting, ``status``), ``frames.py`` (frame fields, connection state); ``limits.py``:
  every bound on what one client can make the bridge hold or do;
- ``graph.py``: the graph's records (topics, services, actions) and its queries;
  ``rosapi.py``: the ``/rosapi`` services over them (neither imports ``protocol.py``).
- :class:`BridgeServer` (``server.py``): WebSocket I/O, immediate or queued ingestion, call
  deadlines; its send side, per-connection batches and bounded queues (``sending.py``: mixed
  into it), and the connection that hands it each message as read, with who may connect
  (``connection.py``).
- :class:`TypeRegistry` (``types.py``): message/service/action definitions.
- :class:`BridgeClient` (``client.py``): client mode with reconnect.
"""

from harness.rosbridge.actions import ActionGoal
from harness.rosbridge.client import BridgeClient
from harness.rosbridge.connection import is_loopback
from harness.rosbridge.errors import ExposedServerWarning
from harness.rosbridge.graph import Message
from harness.rosbridge.outgoing import DIRECTION_IN, DIRECTION_OUT, OutgoingFrame, TapRecord
from harness.rosbridge.protocol import Bridge
from harness.rosbridge.sending import ConnectionMetrics
from harness.rosbridge.server import BridgeServer
from harness.rosbridge.services import DEFERRED, ServiceCall
from harness.rosbridge.types import TypeRegistry

__all__ = [
    "DEFERRED",
    "DIRECTION_IN",
    "DIRECTION_OUT",
    "ActionGoal",
    "Bridge",
    "BridgeClient",
    "BridgeServer",
    "ConnectionMetrics",
    "ExposedServerWarning",
    "Message",
    "OutgoingFrame",
    "ServiceCall",
    "TapRecord",
    "TypeRegistry",
    "is_loopback",
]
