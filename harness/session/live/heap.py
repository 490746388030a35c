"""The process's heap held out of the garbage collector while a realtime session runs.

CPython's full collection walks every tracked object, and a process that imported MuJoCo,
numpy, rosbags and websockets holds ~70k of them: measured here under the 20-client load, one
full collection stopped the session's thread for 107 ms, 50 real-time steps and ~2000 relayed
frames late. :func:`hold` (at a realtime session's start) collects once and moves everything
alive then into the permanent generation (:func:`gc.freeze`), so later collections walk only
what the run itself allocates; :func:`release` (at its close) gives the objects back
(:func:`gc.unfreeze`) when no other realtime session of the process still holds them. What
the run frees by reference counting is freed as ever; only reference cycles among objects
that were alive at the start wait until the release. Collection changes when memory is
freed, never what a step computes.
"""

from __future__ import annotations

import gc
import threading

__all__ = ["hold", "holders", "release"]

_lock = threading.Lock()
_holders = 0


def hold() -> None:
    """Collect and freeze the heap (the first holder), or count one more holder."""
    global _holders
    with _lock:
        if _holders == 0:
            gc.collect()
            gc.freeze()
        _holders += 1


def release() -> None:
    """One holder less; the last one unfreezes the heap."""
    global _holders
    with _lock:
        if _holders == 0:
            return
        _holders -= 1
        if _holders == 0:
            gc.unfreeze()


def holders() -> int:
    """Realtime sessions holding the heap now."""
    return _holders
