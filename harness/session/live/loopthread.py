"""The session's one background thread and the asyncio event loop it runs
(:class:`LoopThread`): started once, handed calls (:meth:`LoopThread.call`) and coroutines
(:meth:`LoopThread.run`) from other threads, which wait for them, and stopped once
(:meth:`LoopThread.stop`). Everything that touches the simulation runs on that loop.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from harness.session.errors import SessionClosedError, SessionError
from harness.session.live.polling import PollingSelector

__all__ = ["LoopThread"]

T = TypeVar("T")


class LoopThread:
    """An event loop (created now) and the daemon thread that will run it. ``closed``: set
    by the owner when it closes (calls are then refused); ``after_call``: run on the loop
    after every :meth:`call`'s function (the session flushes its port there); ``selector``:
    the loop's, which polls before blocking while its ``should_poll`` says so
    (:mod:`harness.session.live.polling`)."""

    def __init__(self) -> None:
        self.selector = PollingSelector()
        self.loop: asyncio.AbstractEventLoop = asyncio.SelectorEventLoop(self.selector)
        self.thread: threading.Thread | None = None
        self.closed = False
        self.after_call: Callable[[], None] | None = None

    def start(self) -> None:
        """Start the thread running the loop."""
        self.thread = threading.Thread(
            target=self.loop.run_forever, name="harness-session", daemon=True
        )
        self.thread.start()

    def on_thread(self) -> bool:
        """Whether the caller runs on the loop's thread."""
        return self.thread is not None and threading.current_thread() is self.thread

    def run(self, coro: Coroutine[Any, Any, T]) -> T:
        """Run ``coro`` on the loop and wait for its result (refused on the loop's own thread
        and once closed)."""
        if self.on_thread():
            coro.close()
            raise SessionError(
                "this session method waits for the simulation: it cannot be called from the "
                "session's own thread (a predicate, logger or callback)"
            )
        if self.closed or self.thread is None or not self.thread.is_alive():
            coro.close()
            raise SessionClosedError("the session is closed")
        self.selector.called = True
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result()

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn`` on the loop's thread (directly when already there)."""
        if self.on_thread():
            return fn()
        if self.closed or self.thread is None or not self.thread.is_alive():
            raise SessionClosedError("the session is closed")
        future: concurrent.futures.Future[T] = concurrent.futures.Future()

        def run() -> None:
            try:
                future.set_result(fn())
            except BaseException as exc:
                future.set_exception(exc)
            finally:
                if self.after_call is not None:
                    self.after_call()  # what fn made the core produce

        self.selector.called = True
        self.loop.call_soon_threadsafe(run)
        return future.result()

    def stop(self, shutdown: Callable[[], Coroutine[Any, Any, None]]) -> list[BaseException]:
        """Run ``shutdown()`` on the loop (when its thread runs), stop the loop, join the
        thread and close the loop; returns the error ``shutdown`` raised, if any."""
        loop = self.loop
        thread = self.thread
        errors: list[BaseException] = []
        if thread is not None and thread.is_alive():
            try:
                asyncio.run_coroutine_threadsafe(shutdown(), loop).result()
            except Exception as exc:
                errors.append(exc)
            loop.call_soon_threadsafe(loop.stop)
            thread.join()
        if not loop.is_running():
            loop.close()
        return errors
