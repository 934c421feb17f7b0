"""Inputs that used to answer 500 or cost far more than they weigh: each is now a 4xx naming the field, and
leaves the session exactly as it was."""

from __future__ import annotations

import base64
import contextlib
import io
import json
import struct
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from app_support import SMALL_CAMERA, new_session, oracle_observation, post_step
from fastapi.testclient import TestClient
from PIL import Image

from app.main import create_app
from app.settings import Settings


def _pose(x: float, z: float = 0.0) -> dict[str, float]:
    return {"x": x, "z": z, "yaw": 90.0, "horizon": 30.0}


def _live_sessions(client: TestClient) -> int:
    return len(client.app.state.store)  # type: ignore[attr-defined]


def _readable_state(client: TestClient, session_id: str) -> dict[str, bytes]:
    """Everything a client can read of a session, as bytes."""
    return {
        route: client.get(f"/v1/sessions/{session_id}{route}").content for route in ("", "/trace", "/map.png")
    }


def _jpeg_declaring(width: int, height: int) -> bytes:
    """A real 32x24 JPEG whose frame header declares ``width`` x ``height`` (what a decoder allocates)."""
    buffer = io.BytesIO()
    Image.fromarray(np.zeros((24, 32, 3), dtype=np.uint8)).save(buffer, "jpeg")
    data = bytearray(buffer.getvalue())
    sof = data.find(b"\xff\xc0")
    data[sof + 5 : sof + 9] = struct.pack(">HH", height, width)
    return bytes(data)


# ---- 1. a pose the map cannot hold --------------------------------------------------------------------


def test_a_pose_beyond_the_map_is_refused_and_the_session_is_untouched(client: TestClient) -> None:
    refused_id, control_id = new_session(client), new_session(client)
    first = {**oracle_observation(), "pose": _pose(-0.375)}
    for session_id in (refused_id, control_id):
        assert post_step(client, session_id, {**first, "step": 0}).status_code == 200
    before = _readable_state(client, refused_id)

    response = post_step(client, refused_id, {**oracle_observation(), "pose": _pose(30.0), "step": 1})

    assert response.status_code == 422, response.text
    assert response.json()["error"] == "invalid_pose"
    assert response.json()["detail"].startswith("pose: ")
    assert _readable_state(client, refused_id) == before
    for index in range(1, 6):  # the refused session goes on exactly as one that never got the bad step
        body = {**oracle_observation(), "pose": _pose(-0.375 + 0.25 * (index % 2)), "step": index}
        refused, control = post_step(client, refused_id, body), post_step(client, control_id, body)
        assert refused.status_code == control.status_code == 200
        assert refused.json() == control.json()
    assert client.get(f"/v1/sessions/{refused_id}/map.png").content == (
        client.get(f"/v1/sessions/{control_id}/map.png").content
    )


@pytest.mark.parametrize("x", [1e9, -1e9, 100.5, 1e308])
def test_a_pose_outside_the_house_is_a_validation_error(client: TestClient, x: float) -> None:
    session_id = new_session(client)

    response = post_step(client, session_id, {**oracle_observation(), "pose": _pose(x)})

    assert response.status_code == 422, response.text
    assert response.json()["error"] == "validation_error"
    assert "pose.x" in response.json()["detail"]
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == 0


# ---- 2. legend ids beyond any instance image ----------------------------------------------------------


def test_a_legend_id_beyond_32_bits_is_invalid_segmentation(client: TestClient) -> None:
    session_id = new_session(client)
    body = oracle_observation()
    body["segmentation_legend"] = {**body["segmentation_legend"], "100000000000000000000": "Knife"}

    response = post_step(client, session_id, body)

    assert response.status_code == 422, response.text
    assert response.json()["error"] == "invalid_segmentation"
    assert response.json()["detail"].startswith("segmentation_legend: ")
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == 0


# ---- 3. cameras no step can use -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [("hfov_deg", 1e-300), ("hfov_deg", 5.0), ("hfov_deg", 179.0), ("height_m", 1e-300), ("height_m", 50.0)],
)
def test_a_camera_no_step_could_use_is_refused_at_creation(
    client: TestClient, field: str, value: float
) -> None:
    response = client.post(
        "/v1/sessions",
        json={"mode": "tfd", "subgoals": "Slice Bread", "camera": {**SMALL_CAMERA, field: value}},
    )

    assert response.status_code == 422, response.text
    assert response.json()["error"] == "validation_error"
    assert f"camera.{field}" in response.json()["detail"]
    assert _live_sessions(client) == 0


# ---- 5. images whose header declares a huge size ------------------------------------------------------


def test_a_jpeg_declaring_a_huge_size_is_refused_from_its_header_in_json_and_multipart(
    client: TestClient,
) -> None:
    session_id = new_session(client)
    bomb = _jpeg_declaring(16000, 16000)
    body = {**oracle_observation(), "rgb": base64.b64encode(bomb).decode()}

    as_json = post_step(client, session_id, body)
    fields = {k: json.dumps(v) if not isinstance(v, str) else v for k, v in body.items() if k != "rgb"}
    files = {"rgb": ("rgb.jpeg", bomb, "image/jpeg")}
    for name in ("depth", "segmentation"):
        files[name] = (f"{name}.png", base64.b64decode(fields.pop(name)), "image/png")
    as_multipart = client.post(f"/v1/sessions/{session_id}/step", data=fields, files=files)

    for response in (as_json, as_multipart):
        assert response.status_code == 422, response.text
        assert response.json() == {
            "error": "invalid_image",
            "detail": "rgb: is 16000x16000 pixels but the session camera is 32x24",
        }
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == 0


# ---- 6. EDH histories longer than any game ------------------------------------------------------------


def test_an_edh_history_over_the_limit_answers_413_before_any_work(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(max_history_actions=10)
    history = {"actions": [{"action_name": "Forward"}] * 11}

    response = client.post(
        "/v1/sessions", json={"mode": "edh", "subgoals": "Slice Bread", "history": history}
    )

    assert response.status_code == 413, response.text
    assert response.json()["error"] == "history_too_long"
    assert "history.actions has 11 actions" in response.json()["detail"]
    assert "JARVIS_MAX_HISTORY_ACTIONS" in response.json()["detail"]
    assert _live_sessions(client) == 0


def test_a_history_at_the_limit_is_accepted(make_client: Callable[..., TestClient]) -> None:
    client = make_client(max_history_actions=10)
    history = {"actions": [{"action_name": "Forward"}] * 10}

    response = client.post(
        "/v1/sessions", json={"mode": "edh", "subgoals": "Slice Bread", "history": history}
    )

    assert response.status_code == 201, response.text


def test_a_teach_start_with_a_history_over_the_limit_answers_413(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(max_history_actions=10)
    instance = {
        "instance_id": "x.edh0",
        "dialog_history": [["Commander", "make toast"]],
        "driver_action_history": [{"action_name": "Forward"}] * 11,
    }

    response = client.post(
        "/start_new_edh_instance", data={"edh_name": "x", "edh_instance": json.dumps(instance)}
    )

    assert response.status_code == 413, response.text
    assert response.json()["error"] == "history_too_long"
    assert "edh_instance.driver_action_history has 11 actions" in response.json()["detail"]


def test_the_default_history_frame_limit_is_a_real_edh_instance_s() -> None:
    settings = Settings()
    assert settings.max_edh_history_frames <= 1000
    assert settings.max_history_actions <= 1000


# ---- 7. requests that queued past their deadline ------------------------------------------------------


def _one_worker_thread_app() -> Any:
    """An app with one worker thread and a 0.2 s queue deadline, plus a route that holds the thread 0.8 s
    (this test's app only, never the shipped one)."""
    app = create_app(Settings(request_queue_deadline_s=0.2, requests_per_worker=1, log_level="warning"))

    def hold_the_worker() -> dict[str, str]:
        time.sleep(0.8)
        return {"held": "the only worker thread"}

    app.add_api_route("/test-only/hold", hold_the_worker)
    return app


@contextlib.contextmanager
def _worker_held(client: TestClient) -> Iterator[dict[str, Any]]:
    """The block runs while another request holds the only worker thread; its answer is ``["held"]``."""
    answers: dict[str, Any] = {}
    holder = threading.Thread(target=lambda: answers.update(held=client.get("/test-only/hold")))
    holder.start()
    time.sleep(0.2)  # the holder has the thread now
    yield answers
    holder.join()


def test_a_request_that_queued_past_the_deadline_answers_503_and_does_nothing() -> None:
    """One worker thread, held by a slow handler: the next request waits for it past the deadline."""
    with TestClient(_one_worker_thread_app(), raise_server_exceptions=False) as client:
        with _worker_held(client) as answers:
            queued = client.post("/v1/sessions", json={"mode": "tfd", "subgoals": "Slice Bread"})

        assert answers["held"].status_code == 200
        assert queued.status_code == 503, queued.text
        assert queued.json()["error"] == "overloaded"
        assert "JARVIS_REQUEST_QUEUE_DEADLINE_S" in queued.json()["detail"]
        assert int(queued.headers["Retry-After"]) >= 1
        assert _live_sessions(client) == 0  # nothing was created
        assert client.get("/healthz").status_code == 200


def test_a_step_that_queued_past_the_deadline_answers_503_and_leaves_the_session_as_it_was() -> None:
    """The step route takes one worker thread for all its work and checks the deadline first in it."""
    with TestClient(_one_worker_thread_app(), raise_server_exceptions=False) as client:
        session_id = new_session(client)
        before = _readable_state(client, session_id)
        with _worker_held(client):
            queued = post_step(client, session_id, {**oracle_observation(), "pose": _pose(-0.375)})

        assert queued.status_code == 503, queued.text
        assert queued.json()["error"] == "overloaded"
        assert int(queued.headers["Retry-After"]) >= 1
        assert _readable_state(client, session_id) == before
        stepped = post_step(client, session_id, {**oracle_observation(), "pose": _pose(-0.375)})
        assert stepped.status_code == 200, stepped.text  # nothing queues now: the same step goes through


# ---- 405: Allow names every method of the path (found by tests/app/test_schemathesis.py) -------------


@pytest.mark.parametrize(
    ("method", "path", "allowed"),
    [
        ("OPTIONS", "/v1/sessions", "GET, POST"),  # Starlette named only the first route: "POST"
        ("PUT", "/v1/sessions/0123abcd", "DELETE, GET"),  # and here "GET"
        ("GET", "/v1/sessions/0123abcd/step", "POST"),
        ("DELETE", "/healthz", "GET"),
    ],
)
def test_a_405_allows_every_method_the_path_serves(
    client: TestClient, method: str, path: str, allowed: str
) -> None:
    response = client.request(method, path)

    assert response.status_code == 405, response.text
    assert response.headers["Allow"] == allowed
    assert response.json() == {
        "error": "method_not_allowed",
        "detail": f"{method} is not allowed on {path}; allowed: {allowed}",
    }
