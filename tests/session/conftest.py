"""Shared pieces of the session tests: demo robots loaded once per worker and clients
(``session_helpers.Client``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from harness.models import LoadedRobot, load_robot
from tests.session.session_helpers import Client


@pytest.fixture
def client_factory() -> Iterator[Callable[[str], Client]]:
    """Open clients (closed at the end of the test)."""
    clients: list[Client] = []

    def make(url: str) -> Client:
        client = Client(url)
        clients.append(client)
        return client

    yield make
    for client in clients:
        client.close()


@pytest.fixture(scope="session")
def demo_position() -> LoadedRobot:
    """The demo arm, every joint position-controlled."""
    return load_robot("demo", control="position")


@pytest.fixture(scope="session")
def demo_kinematic() -> LoadedRobot:
    """The demo arm, every joint kinematic."""
    return load_robot("demo", control="kinematic")
