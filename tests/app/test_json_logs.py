"""Every line the service writes is JSON: its own events, uvicorn's, Python warnings and the model
libraries' (transformers loads the planner at start-up), so a log shipper needs no second parser."""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path

import httpx
import pytest

from app.logging_json import configure_json_logging
from harness.drive.service import running_service

READY_TIMEOUT_S = 120.0  # the models load before /readyz answers 200


def test_the_served_process_writes_only_json_lines(tmp_path: Path) -> None:
    log = tmp_path / "service.log"
    env = {
        "JARVIS_LOG_LEVEL": "debug",  # the most lines, from the most libraries
        "JARVIS_PRELOAD_MODELS": "true",
    }
    with running_service(env=env, log_path=log, startup_timeout_s=READY_TIMEOUT_S) as service:
        dialogue = [{"speaker": "Commander", "text": "make a cup of coffee"}]
        created = httpx.post(
            f"{service.base_url}/v1/sessions", json={"mode": "tfd", "dialogue": dialogue}, timeout=60.0
        )
        missing = httpx.get(f"{service.base_url}/v1/sessions/nope", timeout=10.0)

    assert created.status_code == 201, created.text
    assert missing.status_code == 404
    lines = [line for line in log.read_text(encoding="utf-8").splitlines() if line.strip()]
    not_json = []
    for line in lines:
        try:
            json.loads(line)
        except ValueError:
            not_json.append(line)
    assert not not_json, f"{len(not_json)} of {len(lines)} log lines are not JSON, e.g. {not_json[:5]}"
    events = [json.loads(line) for line in lines]
    loggers = {event["logger"] for event in events}
    assert {"uvicorn.error", "app.request", "app.preload"} <= loggers
    assert any(e["event"] == "model_loaded" and e["model"] == "language planner" for e in events)


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
