"""The harness's side of the ROS 2 gateway: starts :mod:`harness.ros2.node` in the ROS 2
interpreter as a rosbridge client of the session's embedded server, hands it the session's
offer, waits until it is ready and stops it. Imports nothing from ROS."""

from __future__ import annotations

import contextlib
import json
import subprocess
import threading
from collections import deque
from pathlib import Path

from harness.ros2.env import Ros2Install, find_ros2
from harness.ros2.errors import Ros2Error
from harness.rosbridge import Offer

__all__ = ["Ros2Gateway"]

_NODE = Path(__file__).with_name("node.py")
_LOG_LINES = 50


class Ros2Gateway:
    """A running gateway process (see :mod:`harness.ros2.node`). ``refused``: what could not be
    mirrored on DDS (``name (type): reason``); ``log``: its last stderr lines."""

    def __init__(self, process: subprocess.Popen[str], domain_id: int) -> None:
        self.process = process
        self.domain_id = domain_id
        self.refused: tuple[str, ...] = ()
        self.log: deque[str] = deque(maxlen=_LOG_LINES)
        self._reader = threading.Thread(target=self._read_stderr, daemon=True)
        self._reader.start()

    @classmethod
    def start(
        cls,
        url: str,
        offer: Offer,
        domain_id: int,
        *,
        install: Ros2Install | None = None,
        timeout: float = 60.0,
    ) -> Ros2Gateway:
        """Start the gateway for the session at ``url`` on ``domain_id`` and wait (wall clock,
        ``timeout``) until it reports ready. Raises :class:`Ros2Error` with its last output."""
        ros = install if install is not None else find_ros2()
        process = subprocess.Popen(
            [str(ros.python), str(_NODE), url],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=ros.environment(domain_id),
        )
        gateway = cls(process, domain_id)
        assert process.stdin is not None
        assert process.stdout is not None
        process.stdin.write(offer.to_json() + "\n")
        process.stdin.close()
        line: list[str] = []
        reader = threading.Thread(target=lambda: line.append(process.stdout.readline()))  # type: ignore[union-attr]
        reader.start()
        reader.join(timeout)
        text = line[0] if line else ""
        if not text.startswith("ready "):
            gateway.stop()
            why = " | ".join(gateway.log) or "no output"
            raise Ros2Error(
                f"the ROS 2 gateway ({ros.python}) did not become ready within {timeout:g} s: {why}"
            )
        gateway.refused = tuple(json.loads(text[6:]).get("refused", ()))
        return gateway

    def _read_stderr(self) -> None:
        stream = self.process.stderr
        if stream is None:
            return
        for raw in stream:
            self.log.append(raw.rstrip())

    @property
    def alive(self) -> bool:
        """Whether the process still runs."""
        return self.process.poll() is None

    def stop(self, timeout: float = 10.0) -> None:
        """SIGTERM, then SIGKILL after ``timeout`` wall seconds."""
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        with contextlib.suppress(Exception):
            if self.process.stdout is not None:
                self.process.stdout.close()
        self._reader.join(1.0)
