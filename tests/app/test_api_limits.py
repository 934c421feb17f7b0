"""Limits through HTTP: session cap (429), idle expiry (404), body size (413) with and without a length."""

from __future__ import annotations

from collections.abc import Callable

from app_support import FakeClock
from fastapi.testclient import TestClient

GOOD = {"mode": "tfd", "subgoals": "Slice Bread"}


def test_creation_at_the_cap_answers_429_and_a_delete_frees_a_slot(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(max_sessions=2)
    first = client.post("/v1/sessions", json=GOOD).json()["session_id"]
    client.post("/v1/sessions", json=GOOD)

    refused = client.post("/v1/sessions", json=GOOD)
    client.delete(f"/v1/sessions/{first}")
    accepted = client.post("/v1/sessions", json=GOOD)

    assert refused.status_code == 429
    assert refused.json()["error"] == "too_many_sessions"
    assert "2 sessions" in refused.json()["detail"]
    assert 1 <= int(refused.headers["Retry-After"]) <= 60  # the oldest idle session's expiry
    assert accepted.status_code == 201


def test_idle_session_expires_after_the_ttl(make_client: Callable[..., TestClient], clock: FakeClock) -> None:
    client = make_client(session_ttl_s=60.0)
    idle = client.post("/v1/sessions", json=GOOD).json()["session_id"]
    used = client.post("/v1/sessions", json=GOOD).json()["session_id"]

    clock.advance(45.0)
    assert client.get(f"/v1/sessions/{used}").status_code == 200  # reading counts as use
    clock.advance(30.0)

    assert client.get(f"/v1/sessions/{used}").status_code == 200
    expired = client.get(f"/v1/sessions/{idle}")
    assert expired.status_code == 404
    assert expired.json()["error"] == "session_not_found"
    assert "idle" in expired.json()["detail"]


def test_declared_oversize_body_is_refused_before_reading(make_client: Callable[..., TestClient]) -> None:
    client = make_client(max_body_bytes=2048)

    response = client.post(
        "/v1/sessions", content=b"{" + b" " * 4096 + b"}", headers={"content-type": "application/json"}
    )

    assert response.status_code == 413
    assert response.json() == {
        "error": "payload_too_large",
        "detail": "the request body declares 4098 bytes; the limit is 2048 bytes "
        "(setting JARVIS_MAX_BODY_BYTES)",
    }


def test_streamed_body_without_length_is_cut_off_at_the_limit(make_client: Callable[..., TestClient]) -> None:
    client = make_client(max_body_bytes=2048)

    def chunks():  # type: ignore[no-untyped-def]
        yield b'{"mode": "tfd", "subgoals": "'
        for _ in range(10):
            yield b"Slice Bread, " * 40
        yield b'"}'

    response = client.post("/v1/sessions", content=chunks(), headers={"content-type": "application/json"})

    assert response.status_code == 413
    assert response.json()["error"] == "payload_too_large"
    assert "streamed more than 2048 bytes" in response.json()["detail"]
    assert len(client.app.state.store) == 0  # type: ignore[attr-defined]
