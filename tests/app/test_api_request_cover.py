"""Through the service with the model planner: a request for two objects gives a plan that handles both,
and the repair log says where the second came from (issue 62)."""

from __future__ import annotations

from fastapi.testclient import TestClient


def test_a_dialogue_asking_for_a_mug_and_a_pan_plans_both(client: TestClient) -> None:
    dialogue = [
        {"speaker": "Driver", "text": "hello, what can I do?"},
        {"speaker": "Commander", "text": "please clean a mug and a pan"},
    ]
    response = client.post("/v1/sessions", json={"mode": "tfd", "planner": "model", "dialogue": dialogue})
    assert response.status_code == 201, response.text
    plan = response.json()["plan"]
    texts = [s["text"] for s in plan["subgoals"]]
    assert "Pickup Mug" in texts and "Pickup Pan" in texts, texts
    pan = texts.index("Pickup Pan")
    assert "Place SinkBasin" in texts[pan:] and "ToggleOn Faucet" in texts[pan:], texts
    added = [event for event in plan["repair_log"] if event["rule"] == "request-conjunction"]
    assert added, plan["repair_log"]  # the model alone plans only the mug
    assert "mug and a pan" in added[0]["reason"]
