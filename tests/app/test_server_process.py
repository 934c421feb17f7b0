"""What ``make serve`` + curl does: the real server in a subprocess, the acceptance request over TCP."""

from __future__ import annotations

import json
from pathlib import Path

import httpx

from harness.drive.service import running_service


def test_served_acceptance_request_and_json_logs(tmp_path: Path) -> None:
    log = tmp_path / "service.log"
    with running_service(env={"JARVIS_LOG_LEVEL": "info"}, log_path=log) as service:
        response = httpx.post(
            f"{service.base_url}/v1/sessions",
            json={"mode": "tfd", "planner": "oracle", "subgoals": "Slice Bread"},
            timeout=10.0,
        )

    assert response.status_code == 201, response.text
    plan = response.json()["plan"]
    assert plan["text"].startswith("Navigate Knife, Pickup Knife")
    assert "slice-needs-knife" in [event["rule"] for event in plan["repair_log"]]
    events = [json.loads(line) for line in log.read_text(encoding="utf-8").splitlines() if line.strip()]
    names = [event["event"] for event in events]
    assert "service_ready" in names and "session_created" in names
    assert all("color_message" not in event for event in events)
    request_log = next(e for e in events if e["event"] == "http_request" and e["path"] == "/v1/sessions")
    assert request_log["status"] == 201 and request_log["method"] == "POST"
