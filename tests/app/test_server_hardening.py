"""Behaviour only a real server shows: a 500 keeps the keep-alive connection usable, and a body that stops
arriving is answered 408 and closed. uvicorn runs in a thread, serving an app built here."""

from __future__ import annotations

import json
import socket
import time

import httpx
from app_support import serving

from app.main import create_app
from app.settings import Settings


def test_after_a_500_the_same_keep_alive_connection_serves_the_next_request() -> None:
    app = create_app(Settings(log_level="critical"))

    def fails() -> None:
        raise RuntimeError("a bug the service did not foresee")

    app.add_api_route("/test-only/fails", fails)  # this test's app only, never the shipped one
    with serving(app) as base_url, httpx.Client(base_url=base_url, timeout=10.0) as client:
        failed = client.get("/test-only/fails")
        created = client.post("/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread"})
        again = client.get(f"/v1/sessions/{created.json()['session_id']}")

    assert failed.status_code == 500
    assert failed.json() == {
        "error": "internal_error",
        "detail": "unexpected RuntimeError while serving the request; see the server log",
    }
    assert failed.headers.get("connection", "").lower() != "close"
    assert created.status_code == 201, created.text
    assert again.status_code == 200


def test_one_connection_carries_a_500_and_the_next_request() -> None:
    """The same, on a raw socket, so it is certain both answers came over one TCP connection."""
    app = create_app(Settings(log_level="critical"))

    def fails() -> None:
        raise RuntimeError("a bug the service did not foresee")

    app.add_api_route("/test-only/fails", fails)
    with serving(app) as base_url, socket.create_connection(_address(base_url), timeout=10) as sock:
        reader = sock.makefile("rb")
        sock.sendall(b"GET /test-only/fails HTTP/1.1\r\nHost: test\r\n\r\n")
        status_500, _, body_500 = _read_response(reader)
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: test\r\n\r\n")
        status_ok, _, body_ok = _read_response(reader)

    assert status_500 == 500 and json.loads(body_500)["error"] == "internal_error"
    assert status_ok == 200 and json.loads(body_ok)["status"] == "ok"


def test_a_body_that_stops_arriving_answers_408_closes_and_changes_nothing() -> None:
    app = create_app(Settings(body_read_timeout_s=0.5, log_level="critical"))
    with serving(app) as base_url:
        created = httpx.post(f"{base_url}/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread"})
        session_id = created.json()["session_id"]
        with socket.create_connection(_address(base_url), timeout=10) as sock:
            reader = sock.makefile("rb")
            sock.sendall(
                f"POST /v1/sessions/{session_id}/step HTTP/1.1\r\nHost: test\r\n"
                "Content-Type: application/json\r\nContent-Length: 1000\r\n\r\n".encode()
                + b'{"rgb": "iVBO'
            )
            started = time.monotonic()
            status, headers, body = _read_response(reader)
            waited = time.monotonic() - started
            closed = reader.read() == b""  # the server closed its end
        after = httpx.get(f"{base_url}/v1/sessions/{session_id}")

    assert status == 408
    assert json.loads(body)["error"] == "request_timeout"
    assert "JARVIS_BODY_READ_TIMEOUT_S" in json.loads(body)["detail"]
    assert headers.get("connection") == "close" and closed
    assert 0.4 < waited < 5.0
    assert after.json()["step"] == 0


def _address(base_url: str) -> tuple[str, int]:
    host, port = base_url.removeprefix("http://").split(":")
    return host, int(port)


def _read_response(reader: object) -> tuple[int, dict[str, str], bytes]:
    """Status, lower-cased headers and body of one HTTP/1.1 response with a Content-Length."""
    assert hasattr(reader, "readline") and hasattr(reader, "read")
    status_line = reader.readline().decode()
    status = int(status_line.split()[1])
    headers: dict[str, str] = {}
    while (line := reader.readline().decode().strip()) != "":
        name, _, value = line.partition(":")
        headers[name.strip().lower()] = (
            value.strip().lower() if name.lower() == "connection" else value.strip()
        )
    body = reader.read(int(headers.get("content-length", "0")))
    return status, headers, body
