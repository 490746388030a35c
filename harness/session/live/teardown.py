"""The pieces of :meth:`Session.close <harness.session.Session.close>`: the deterministic close
of the port (:func:`close_port`), the driver's and the loop's other tasks' end
(:func:`stop_driver`, :func:`cancel_other_tasks`), run on the session's loop before its
thread ends (:meth:`~harness.session.live.loopthread.LoopThread.stop`). What they guarantee:

:meth:`Session.close <harness.session.Session.close>` ends a recording the same way for the
same client behaviour: the free-running clock stops; the frames already received are
processed as at any step boundary; the server sends every client a close frame and, until
each closing handshake completes, keeps processing what the clients still send, in arrival
order; each socket's closing is a ``harness/disconnect`` marker where it arrives; then a
``harness/close`` marker records the last step ``k``, a connection somehow still open gets a
disconnect marker, loggers finish and the recording is closed. So the recording holds every
frame a client sent before it received the server's close frame, processed exactly as if it
had been processed before ``close()`` was called: in lockstep a late ``/harness/step``
request still steps (refusing it would make the recording depend on whether the idle loop got
to it before ``close()``); otherwise the frames take effect at step ``k + 1``, which is never
taken. What remains timing-dependent is only how far a client got before the close frame
reached it: a client still sending while the session closes (a library's goodbye
``unsubscribe`` racing ``close()``) may or may not have its last frames recorded, and a
client that does not answer the closing handshake within 10 s is cut off. With a
free-running clock, which step a frame lands on is wall-clock timing anyway. Golden
comparisons ignore exactly the frames after the last step (:func:`harness.replay.diff` with
``ignore_after_last_step=True``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

from harness.session.core.engine import SessionCore
from harness.session.live.ports import Port

__all__ = ["cancel_other_tasks", "close_port", "stop_driver"]


async def stop_driver(driver: asyncio.Task[None] | None) -> None:
    """Cancel the session's driver task (if it was started) and wait for its end."""
    if driver is not None:
        driver.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await driver


async def close_port(core: SessionCore, port: Port, boundary: Callable[[], None]) -> None:
    """Deterministic close (module docstring): marker, every frame received processed (by
    ``boundary``, the session's step boundary) while the closing handshakes complete, a
    disconnect for every connection."""
    bridge = core.bridge
    try:
        if bridge is None:
            return
        boundary()
        await asyncio.sleep(0)  # answers to those frames leave before the close frames
    finally:
        await port.stop(boundary)
    boundary()
    core.record_close()
    for connection in bridge.connections:
        bridge.disconnect(connection)
    bridge.drain()  # nobody to send to


async def cancel_other_tasks() -> None:
    """Cancel every task of the running loop but the current one, wait for them, and shut
    the loop's default executor down."""
    current = asyncio.current_task()
    others = [t for t in asyncio.all_tasks() if t is not current]
    for task in others:
        task.cancel()
    await asyncio.gather(*others, return_exceptions=True)
    await asyncio.get_running_loop().shutdown_default_executor()
