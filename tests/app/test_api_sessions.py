"""Sessions over HTTP: the acceptance example, reading, deleting, utterances, EDH history, defaults."""

from __future__ import annotations

from fastapi.testclient import TestClient

from agent.explorers import DEFAULT_EXPLORER
from symbolic.thor import CAMERA_HEIGHT_M

ACCEPTANCE = {"mode": "tfd", "planner": "oracle", "subgoals": "Slice Bread"}


def _texts(subgoals: list[dict[str, str]]) -> list[str]:
    return [subgoal["text"] for subgoal in subgoals]


def test_acceptance_slice_bread_first_fetches_a_knife_and_logs_the_rule(client: TestClient) -> None:
    response = client.post("/v1/sessions", json=ACCEPTANCE)

    assert response.status_code == 201, response.text
    body = response.json()
    plan = body["plan"]
    assert _texts(plan["subgoals"])[:2] == ["Navigate Knife", "Pickup Knife"]
    assert _texts(plan["subgoals"])[-1] == "Slice Bread"
    assert plan["text"].startswith("Navigate Knife, Pickup Knife")
    assert plan["source"] == "oracle" and plan["pointer"] == 0
    rules = [event["rule"] for event in plan["repair_log"]]
    assert "slice-needs-knife" in rules, rules
    knife_event = plan["repair_log"][rules.index("slice-needs-knife")]
    assert "Pickup Knife" in _texts(knife_event["inserted"])
    assert knife_event["reason"]
    assert response.headers["location"] == f"/v1/sessions/{body['session_id']}"


def test_get_returns_what_create_returned(client: TestClient) -> None:
    created = client.post("/v1/sessions", json=ACCEPTANCE).json()

    fetched = client.get(f"/v1/sessions/{created['session_id']}")

    assert fetched.status_code == 200
    assert fetched.json() == created


def test_delete_then_get_and_utterance_answer_404(client: TestClient) -> None:
    session_id = client.post("/v1/sessions", json=ACCEPTANCE).json()["session_id"]

    assert client.delete(f"/v1/sessions/{session_id}").status_code == 204
    after_get = client.get(f"/v1/sessions/{session_id}")
    after_utterance = client.post(
        f"/v1/sessions/{session_id}/utterances", json={"speaker": "Commander", "text": "hello"}
    )
    again = client.delete(f"/v1/sessions/{session_id}")

    for response in (after_get, after_utterance, again):
        assert response.status_code == 404
        assert response.json()["error"] == "session_not_found"
        assert session_id in response.json()["detail"]


def test_commander_utterance_is_recorded_without_replanning_an_oracle_plan(client: TestClient) -> None:
    created = client.post("/v1/sessions", json=ACCEPTANCE).json()

    response = client.post(
        f"/v1/sessions/{created['session_id']}/utterances",
        json={"speaker": "Commander", "text": "Actually, toast it too."},
    )

    assert response.status_code == 200, response.text
    result = response.json()
    assert result["replanned"] is False
    assert "does not re-plan" in result["note"]
    assert result["session"]["dialogue"] == [{"speaker": "Commander", "text": "Actually, toast it too."}]
    assert result["session"]["plan"] == created["plan"]
    assert result["session"]["updated_at"] >= created["updated_at"]


def test_follower_is_stored_as_driver(client: TestClient) -> None:
    body = {**ACCEPTANCE, "dialogue": [{"speaker": "Follower", "text": "What should I do?"}]}

    created = client.post("/v1/sessions", json=body).json()

    assert created["dialogue"] == [{"speaker": "Driver", "text": "What should I do?"}]


def test_edh_history_holding_a_knife_needs_no_knife_fetch(client: TestClient) -> None:
    history = {
        "actions": [
            {"action_name": "Forward", "action_id": 2},
            {
                "action_name": "Pickup",
                "action_id": 200,
                "oid": "Knife|+01.00|+00.90|-00.50",
                "x": 0.5,
                "y": 0.6,
            },
        ]
    }

    created = client.post(
        "/v1/sessions", json={"mode": "edh", "subgoals": "Navigate Bread, Slice Bread", "history": history}
    ).json()

    assert _texts(created["history_subgoals"]) == ["Navigate Knife", "Pickup Knife"]
    assert created["plan"]["text"] == "Navigate Bread, Slice Bread"
    assert created["plan"]["repair_log"] == []


def test_subgoals_in_every_accepted_form_give_the_same_plan(client: TestClient) -> None:
    forms = [
        "Navigate Apple, Pickup Apple",
        ["Navigate Apple", "Pickup Apple"],
        ["Navigate", "Apple", "Pickup", "Apple"],
        [{"action": "Navigate", "object": "Apple"}, {"action": "PickUp", "object": "apples"}],
    ]

    plans = [
        client.post("/v1/sessions", json={"mode": "tfd", "subgoals": form}).json()["plan"] for form in forms
    ]

    assert all(plan["text"] == "Navigate Apple, Pickup Apple" for plan in plans), plans


def test_defaults_oracle_planner_fmm_navigator_and_mode_cameras(client: TestClient) -> None:
    teach = client.post("/v1/sessions", json={"mode": "tatc", "subgoals": "Open Fridge"}).json()
    alfred = client.post(
        "/v1/sessions",
        json={"mode": "instruction", "subgoals": "Open Fridge", "instruction": "Open the fridge."},
    ).json()

    assert (teach["planner"], teach["navigator"], teach["perception"]) == ("oracle", "fmm", "oracle")
    assert teach["camera"] == {"width": 900, "height": 900, "hfov_deg": 90.0, "height_m": CAMERA_HEIGHT_M}
    assert alfred["camera"] == {"width": 300, "height": 300, "hfov_deg": 60.0, "height_m": CAMERA_HEIGHT_M}
    assert alfred["instruction"] == "Open the fridge."
    assert teach["explorer"] == DEFAULT_EXPLORER


def test_the_explorer_can_be_chosen_and_an_unknown_one_is_refused(client: TestClient) -> None:
    chosen = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Open Fridge", "explorer": "goal_transformer"}
    )
    assert chosen.status_code == 201
    assert client.get(f"/v1/sessions/{chosen.json()['session_id']}").json()["explorer"] == "goal_transformer"
    refused = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Open Fridge", "explorer": "random"}
    )
    assert refused.status_code == 422 and refused.json()["error"] == "validation_error", refused.json()
    assert "explorer" in refused.json()["detail"]
