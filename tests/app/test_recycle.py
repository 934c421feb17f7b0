"""Keep-alive connections end every ``requests_per_connection`` answers, so clients reconnect and the
kernel spreads them over the worker processes again (``app.recycle``)."""

from __future__ import annotations

from collections.abc import Callable

from fastapi.testclient import TestClient


def test_every_nth_answer_on_a_connection_closes_it(make_client: Callable[..., TestClient]) -> None:
    client = make_client(requests_per_connection=3)  # TestClient: one peer address, one "connection"

    answers = [client.get("/v1/sessions") for _ in range(7)]

    closing = [i for i, answer in enumerate(answers, start=1) if answer.headers.get("connection") == "close"]
    assert closing == [3, 6]
    assert all(answer.status_code == 200 for answer in answers)


def test_an_error_answer_counts_and_closes_too(make_client: Callable[..., TestClient]) -> None:
    client = make_client(requests_per_connection=2)

    first = client.get("/v1/sessions/nope")
    second = client.get("/v1/sessions/nope")

    assert first.status_code == second.status_code == 404
    assert "connection" not in first.headers and second.headers["connection"] == "close"
