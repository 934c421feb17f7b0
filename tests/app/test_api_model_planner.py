"""The language planner behind the session API: the default without subgoals, re-planning on the
commander's words, and a clear 422 when its checkpoint cannot be loaded."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from fastapi.testclient import TestClient

COFFEE = [
    {"speaker": "Driver", "text": "hi, what should I do?"},
    {"speaker": "Commander", "text": "make a cup of coffee"},
]


def _texts(plan: dict[str, object]) -> list[str]:
    return [str(s["text"]) for s in plan["subgoals"]]  # type: ignore[attr-defined]


def test_without_subgoals_the_model_plans_from_the_dialogue(client: TestClient) -> None:
    response = client.post("/v1/sessions", json={"mode": "tfd", "dialogue": COFFEE})
    assert response.status_code == 201, response.text
    body = response.json()
    assert body["planner"] == "model"
    assert body["plan"]["source"] == "model"
    texts = _texts(body["plan"])
    assert texts[:2] == ["Navigate Mug", "Pickup Mug"]
    assert "Place CoffeeMachine" in texts
    assert float(response.headers["X-Planner-Time-Ms"]) > 0  # its own time, apart from any queue


def test_only_answers_the_planner_worked_on_carry_its_time(client: TestClient) -> None:
    given = client.post("/v1/sessions", json={"mode": "tfd", "dialogue": COFFEE, "subgoals": "Slice Bread"})
    assert given.status_code == 201 and "X-Planner-Time-Ms" not in given.headers
    session = given.json()["session_id"]
    assert "X-Planner-Time-Ms" not in client.get(f"/v1/sessions/{session}").headers


def test_a_commander_turn_replans_and_a_session_without_words_waits_for_one(client: TestClient) -> None:
    created = client.post("/v1/sessions", json={"mode": "tfd"}).json()
    assert created["plan"]["subgoals"] == []  # nothing said yet: nothing to plan
    session = created["session_id"]
    answer = client.post(
        f"/v1/sessions/{session}/utterances", json={"speaker": "Commander", "text": "make a cup of coffee"}
    )
    assert answer.status_code == 200, answer.text
    assert answer.json()["replanned"] is True
    assert "Place CoffeeMachine" in _texts(answer.json()["session"]["plan"])
    follower = client.post(f"/v1/sessions/{session}/utterances", json={"speaker": "Driver", "text": "ok"})
    assert follower.json()["replanned"] is False


def test_an_unloadable_checkpoint_is_a_clear_422_and_stores_nothing(
    make_client: Callable[..., TestClient], tmp_path: Path
) -> None:
    client = make_client(planner_checkpoint=tmp_path / "missing")
    response = client.post("/v1/sessions", json={"mode": "tfd", "dialogue": COFFEE})
    assert response.status_code == 422
    assert response.json()["error"] == "planner_unavailable"
    assert "checkpoint" in response.json()["detail"]
    oracle = client.post("/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread"})
    assert oracle.status_code == 201  # the oracle planner needs no model
