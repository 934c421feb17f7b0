"""The real app behind FastAPI's TestClient, with small limits so each limit is cheap to reach."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest
from app_support import FakeClock
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings

SMALL_LIMITS: dict[str, Any] = {
    "max_sessions": 4,
    "session_ttl_s": 60.0,
    "max_body_bytes": 64 * 1024,
    "max_image_side": 1024,
    "max_dialogue_turns": 5,
    "max_utterance_chars": 100,
    "max_subgoals": 20,
    "session_lock_timeout_s": 0.2,
    "log_level": "warning",
    "preload_models": False,  # models load on first use: most app tests need none (test_readiness.py)
}


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def make_client(clock: FakeClock) -> Iterator[Callable[..., TestClient]]:
    """``make_client(**settings_overrides)``: a started app (lifespan run) with SMALL_LIMITS."""
    clients: list[TestClient] = []

    def make(**overrides: Any) -> TestClient:
        settings = Settings(**{**SMALL_LIMITS, **overrides})
        client = TestClient(create_app(settings, clock=clock), raise_server_exceptions=False)
        client.__enter__()
        clients.append(client)
        return client

    yield make
    for client in clients:
        client.__exit__(None, None, None)


@pytest.fixture
def client(make_client: Callable[..., TestClient]) -> TestClient:
    return make_client()
