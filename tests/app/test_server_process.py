"""What ``make serve`` + curl does: the real server in a subprocess, the acceptance request over TCP."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[2]
STARTUP_TIMEOUT_S = 60.0


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _wait_until_live(base_url: str, server: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while time.monotonic() < deadline:
        assert server.poll() is None, f"server exited early with {server.returncode}"
        try:
            if httpx.get(f"{base_url}/readyz", timeout=1.0).status_code == 200:
                return
        except httpx.TransportError:
            time.sleep(0.2)
    raise AssertionError(f"server at {base_url} not ready after {STARTUP_TIMEOUT_S} s")


def test_served_acceptance_request_and_json_logs() -> None:
    port = _free_port()
    env = {**os.environ, "JARVIS_HOST": "127.0.0.1", "JARVIS_PORT": str(port), "JARVIS_LOG_LEVEL": "info"}
    server = subprocess.Popen(
        [sys.executable, "-m", "app"],
        cwd=REPO,
        env=env,
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
    )
    base_url = f"http://127.0.0.1:{port}"
    try:
        _wait_until_live(base_url, server)
        response = httpx.post(
            f"{base_url}/v1/sessions",
            json={"mode": "tfd", "planner": "oracle", "subgoals": "Slice Bread"},
            timeout=10.0,
        )
    finally:
        server.terminate()
        _, stderr = server.communicate(timeout=30)

    assert response.status_code == 201, response.text
    plan = response.json()["plan"]
    assert plan["text"].startswith("Navigate Knife, Pickup Knife")
    assert "slice-needs-knife" in [event["rule"] for event in plan["repair_log"]]
    events = [json.loads(line) for line in stderr.splitlines() if line.strip()]
    names = [event["event"] for event in events]
    assert "service_ready" in names and "session_created" in names
    assert all("color_message" not in event for event in events)
    request_log = next(e for e in events if e["event"] == "http_request" and e["path"] == "/v1/sessions")
    assert request_log["status"] == 201 and request_log["method"] == "POST"
