"""The step route before the executor exists: full validation, an honest 501, no state change, no races."""

from __future__ import annotations

import base64
import threading
from typing import Any

import numpy as np
from app_support import SMALL_CAMERA, oracle_observation, png_base64
from fastapi.testclient import TestClient


def _session(client: TestClient, **extra: Any) -> str:
    body = {"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA, **extra}
    response = client.post("/v1/sessions", json=body)
    assert response.status_code == 201, response.text
    return str(response.json()["session_id"])


def test_valid_oracle_step_is_answered_501_and_leaves_the_session_unchanged(client: TestClient) -> None:
    session_id = _session(client)
    before = client.get(f"/v1/sessions/{session_id}").content
    body = {**oracle_observation(), "pose": {"x": 1.0, "z": 0.5, "yaw": 90.0, "horizon": 30.0}, "step": 0}

    response = client.post(f"/v1/sessions/{session_id}/step", json=body)

    assert response.status_code == 501
    assert response.json()["error"] == "not_implemented"
    assert "agent issue" in response.json()["detail"]
    assert client.get(f"/v1/sessions/{session_id}").content == before


def test_float32_depth_and_learned_rgb_only_are_accepted(client: TestClient) -> None:
    oracle_id = _session(client)
    learned_id = _session(client, perception="learned")
    depth = np.full((SMALL_CAMERA["height"], SMALL_CAMERA["width"]), 1.5, dtype="<f4")
    float_body = {
        **oracle_observation(),
        "depth": base64.b64encode(depth.tobytes()).decode(),
        "depth_encoding": "float32_m",
        "depth_uncertainty": base64.b64encode((depth * 0.1).tobytes()).decode(),
    }
    rgb_only = {"rgb": png_base64(np.zeros((SMALL_CAMERA["height"], SMALL_CAMERA["width"], 3), np.uint8))}

    assert client.post(f"/v1/sessions/{oracle_id}/step", json=float_body).status_code == 501
    assert client.post(f"/v1/sessions/{learned_id}/step", json=rgb_only).status_code == 501


def test_learned_perception_needs_rgb(client: TestClient) -> None:
    session_id = _session(client, perception="learned")

    response = client.post(f"/v1/sessions/{session_id}/step", json={**oracle_observation(), "rgb": None})

    assert response.status_code == 422
    assert response.json()["error"] == "missing_observation"
    assert "rgb" in response.json()["detail"]


def test_step_while_another_request_holds_the_session_answers_409(client: TestClient) -> None:
    session_id = _session(client)
    store = client.app.state.store  # type: ignore[attr-defined]

    with store.hold(session_id, timeout_s=1.0):
        raced = client.post(f"/v1/sessions/{session_id}/step", json=oracle_observation())
    after = client.post(f"/v1/sessions/{session_id}/step", json=oracle_observation())

    assert raced.status_code == 409
    assert raced.json()["error"] == "step_in_progress"
    assert session_id in raced.json()["detail"]
    assert after.status_code == 501


def test_concurrent_steps_of_one_session_are_serialized_or_refused(client: TestClient) -> None:
    session_id = _session(client)
    before = client.get(f"/v1/sessions/{session_id}").content
    statuses: list[int] = []

    def post_steps() -> None:
        for _ in range(4):
            statuses.append(
                client.post(f"/v1/sessions/{session_id}/step", json=oracle_observation()).status_code
            )

    threads = [threading.Thread(target=post_steps) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert len(statuses) == 12
    assert set(statuses) <= {501, 409}, statuses
    assert client.get(f"/v1/sessions/{session_id}").content == before
