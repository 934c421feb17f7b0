"""Every line the service writes is JSON: its own events, uvicorn's, Python warnings and the model
libraries' (transformers loads the planner at start-up), so a log shipper needs no second parser."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import httpx
import pytest
from test_server_process import _free_port

from app.logging_json import configure_json_logging

REPO = Path(__file__).resolve().parents[2]
READY_TIMEOUT_S = 120.0


def _wait_ready(base_url: str, server: subprocess.Popen[str]) -> list[int]:
    """Poll /readyz until 200; the statuses seen on the way."""
    seen: list[int] = []
    deadline = time.monotonic() + READY_TIMEOUT_S
    while time.monotonic() < deadline:
        assert server.poll() is None, f"server exited early with {server.returncode}"
        try:
            seen.append(httpx.get(f"{base_url}/readyz", timeout=2.0).status_code)
            if seen[-1] == 200:
                return seen
        except httpx.TransportError:
            pass
        time.sleep(0.2)
    raise AssertionError(f"server at {base_url} not ready after {READY_TIMEOUT_S} s: {seen[-5:]}")


def test_the_served_process_writes_only_json_lines() -> None:
    port = _free_port()
    env = {
        **os.environ,
        "JARVIS_HOST": "127.0.0.1",
        "JARVIS_PORT": str(port),
        "JARVIS_LOG_LEVEL": "debug",  # the most lines, from the most libraries
        "JARVIS_PRELOAD_MODELS": "true",
    }
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
        statuses = _wait_ready(base_url, server)
        dialogue = [{"speaker": "Commander", "text": "make a cup of coffee"}]
        created = httpx.post(
            f"{base_url}/v1/sessions", json={"mode": "tfd", "dialogue": dialogue}, timeout=60.0
        )
        missing = httpx.get(f"{base_url}/v1/sessions/nope", timeout=10.0)
    finally:
        server.terminate()
        _, stderr = server.communicate(timeout=30)

    assert created.status_code == 201, created.text
    assert missing.status_code == 404
    lines = [line for line in stderr.splitlines() if line.strip()]
    not_json = []
    for line in lines:
        try:
            json.loads(line)
        except ValueError:
            not_json.append(line)
    assert not not_json, f"{len(not_json)} of {len(lines)} stderr lines are not JSON, e.g. {not_json[:5]}"
    events = [json.loads(line) for line in lines]
    loggers = {event["logger"] for event in events}
    assert {"uvicorn.error", "app.request", "app.preload"} <= loggers
    assert any(e["event"] == "model_loaded" and e["model"] == "language planner" for e in events)
    assert 200 in statuses  # (a 503 first when the load outlasts the server's start; the load may be warm)


def test_python_warnings_are_json_lines(capsys: pytest.CaptureFixture[str]) -> None:
    logging.captureWarnings(False)  # pytest restored its own warnings hook after earlier tests captured them
    configure_json_logging("info")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.warn("this API is going away", DeprecationWarning, stacklevel=1)
        event = json.loads(capsys.readouterr().err.strip().splitlines()[-1])
    finally:
        logging.captureWarnings(False)

    assert event["logger"] == "py.warnings"
    assert "DeprecationWarning: this API is going away" in event["event"]
