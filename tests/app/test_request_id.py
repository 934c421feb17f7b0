"""``X-Request-ID``: on every response (refusals included), the client's when sane, and on the log lines."""

from __future__ import annotations

import json
import re
from collections.abc import Callable

import pytest
from fastapi.testclient import TestClient

GENERATED = re.compile(r"[0-9a-f]{32}")  # uuid4 hex


def test_a_sane_client_id_is_echoed(client: TestClient) -> None:
    response = client.get("/healthz", headers={"X-Request-ID": "client-42.retry_1"})

    assert response.headers["X-Request-ID"] == "client-42.retry_1"


@pytest.mark.parametrize(
    "sent",
    [None, "", "has space", "semi;colon", "x" * 129, "ünïcode"],
    ids=["absent", "empty", "space", "semicolon", "too-long", "non-ascii"],
)
def test_an_absent_or_bogus_id_is_replaced_by_a_fresh_one(client: TestClient, sent: str | None) -> None:
    headers = {} if sent is None else {"X-Request-ID": sent.encode()}  # raw UTF-8 bytes for the last case

    first = client.get("/healthz", headers=headers).headers["X-Request-ID"]
    second = client.get("/healthz", headers=headers).headers["X-Request-ID"]

    assert GENERATED.fullmatch(first) and GENERATED.fullmatch(second)
    assert first != second


def test_the_longest_sane_id_is_kept(client: TestClient) -> None:
    sent = "a" * 128

    assert client.get("/healthz", headers={"X-Request-ID": sent}).headers["X-Request-ID"] == sent


@pytest.mark.parametrize(
    ("request_", "status"),
    [
        (lambda c, h: c.get("/v1/sessions/no-such-session", headers=h), 404),
        (lambda c, h: c.post("/v1/sessions", json={"mode": "nonsense"}, headers=h), 422),
        (lambda c, h: c.post("/v1/sessions", content=b"x" * (65 * 1024), headers=h), 413),  # declared length
        (
            lambda c, h: c.post("/v1/sessions", content=iter([b"x" * (40 * 1024)] * 2), headers=h),
            413,
        ),  # streamed
    ],
    ids=["404", "422", "413-declared", "413-streamed"],
)
def test_refusals_carry_the_id_too(
    client: TestClient, request_: Callable[[TestClient, dict[str, str]], object], status: int
) -> None:
    response = request_(client, {"X-Request-ID": "refused-1"})

    assert response.status_code == status  # type: ignore[attr-defined]
    assert response.headers["X-Request-ID"] == "refused-1"  # type: ignore[attr-defined]


def test_every_line_logged_while_serving_carries_the_id(
    capsys: pytest.CaptureFixture[str], make_client: Callable[..., TestClient]
) -> None:
    client = make_client(log_level="info")  # the JSON handler writes to the captured stderr
    capsys.readouterr()

    created = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread"}, headers={"X-Request-ID": "trace-me"}
    )
    missing = client.get("/v1/sessions/nope")

    assert created.status_code == 201
    events = [json.loads(line) for line in capsys.readouterr().err.splitlines() if line.strip()]
    served = [e for e in events if e.get("request_id") == "trace-me"]
    assert {"session_created", "http_request"} <= {e["event"] for e in served}
    request_log = next(e for e in served if e["event"] == "http_request")
    assert request_log["route"] == "/v1/sessions" and request_log["status"] == 201
    refused = next(e for e in events if e["event"] == "http_request" and e["path"] == "/v1/sessions/nope")
    assert refused["request_id"] == missing.headers["X-Request-ID"]
    assert refused["error"] == "session_not_found"
