"""What a person can look at: the ndjson step trace and the semantic map picture."""

from __future__ import annotations

import json

import cv2
import numpy as np
from app_support import SMALL_CAMERA, oracle_observation
from fastapi.testclient import TestClient

POSE = {"x": 1.0, "z": 0.5, "yaw": 90.0, "horizon": 30.0}


def _session_with_steps(client: TestClient, steps: int) -> str:
    created = client.post(
        "/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA}
    )
    session_id = str(created.json()["session_id"])
    for index in range(steps):
        body = {**oracle_observation(), "pose": POSE, "step": index}
        assert client.post(f"/v1/sessions/{session_id}/step", json=body).status_code == 200
    return session_id


def test_the_trace_has_one_json_line_per_step_naming_its_reason(client: TestClient) -> None:
    session_id = _session_with_steps(client, 3)

    response = client.get(f"/v1/sessions/{session_id}/trace")

    assert response.status_code == 200
    assert response.headers["content-type"].startswith("application/x-ndjson")
    lines = [json.loads(line) for line in response.text.splitlines()]
    assert [line["step"] for line in lines] == [0, 1, 2]
    for line in lines:
        assert line["reason"] and line["action"] and line["subgoal"] == "Navigate Knife"
        assert line["inputs"]["depth"] and line["inputs"]["segmentation"] and line["inputs"]["pose"] == POSE
        assert set(line["map"]) >= {"cells", "explored_m2", "obstacle_m2", "points"}
        assert line["timing_ms"]["total"] >= line["timing_ms"]["map"] >= 0
        assert 0 < line["state_bytes"] <= 2_000_000
    assert lines[0]["last_action_success"] is None
    assert lines[1]["last_action"] == lines[0]["action"]
    assert lines[1]["success_evidence"]


def test_the_trace_can_start_at_a_given_step(client: TestClient) -> None:
    session_id = _session_with_steps(client, 3)

    response = client.get(f"/v1/sessions/{session_id}/trace", params={"since": 2})

    assert [json.loads(line)["step"] for line in response.text.splitlines()] == [2]


def test_a_session_without_steps_has_an_empty_trace(client: TestClient) -> None:
    session_id = _session_with_steps(client, 0)

    response = client.get(f"/v1/sessions/{session_id}/trace")

    assert response.status_code == 200 and response.text == ""


def test_the_map_is_a_png_with_the_map_and_its_legend(client: TestClient) -> None:
    session_id = _session_with_steps(client, 2)

    response = client.get(f"/v1/sessions/{session_id}/map.png")

    assert response.status_code == 200
    assert response.headers["content-type"] == "image/png"
    picture = cv2.imdecode(np.frombuffer(response.content, np.uint8), cv2.IMREAD_COLOR)
    assert picture is not None
    height, width, _ = picture.shape
    assert height >= 100 and width >= 300  # the map (3 px per 5 cm cell, 8 m across) and the legend panel
    assert len(np.unique(picture.reshape(-1, 3), axis=0)) > 5


def test_trace_and_map_of_an_unknown_session_are_404(client: TestClient) -> None:
    for path in ("/v1/sessions/nope/trace", "/v1/sessions/nope/map.png"):
        response = client.get(path)
        assert response.status_code == 404
        assert response.json()["error"] == "session_not_found"
