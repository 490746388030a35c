"""The rosbridge v2 layer: a sans-I/O protocol core, the asyncio WebSocket server, rosapi,
ROS 2 message validation and a client for external rosbridge servers. Knows nothing of MuJoCo.

- :class:`Bridge` (``protocol.py``): the shared graph and per-connection state;
  ``receive(connection, frame, now_ns) -> list[Output]``; in-process publishers,
  subscribers, service and action servers; the frames it saw (``frames()``).
- its rooms: ``services.py``, ``actions.py``, ``fragments.py``, ``budget.py`` (ops of those
  concerns, per-client send budgets: mixed into :class:`Bridge`), ``frames.py`` (frame
  fields, connection state); ``limits.py``: every bound on what one client can make the
  bridge hold or do;
- ``graph.py``: the graph's records (topics, services, actions) and its queries;
  ``rosapi.py``: the ``/rosapi`` services over them (neither imports ``protocol.py``).
- :class:`BridgeServer` (``server.py``): WebSocket I/O, immediate or queued ingestion.
- :class:`TypeRegistry` (``types.py``): message/service/action definitions.
- :class:`BridgeClient` (``client.py``): client mode with reconnect.
"""

from harness.rosbridge.client import BridgeClient
from harness.rosbridge.errors import ExposedServerWarning
from harness.rosbridge.protocol import (
    DEFERRED,
    DIRECTION_IN,
    DIRECTION_OUT,
    ActionGoal,
    Bridge,
    Message,
    Output,
    ServiceCall,
    TapRecord,
)
from harness.rosbridge.server import BridgeServer, ConnectionMetrics, is_loopback
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
    "Output",
    "ServiceCall",
    "TapRecord",
    "TypeRegistry",
    "is_loopback",
]
