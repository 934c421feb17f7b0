"""The step route: JSON and multipart bodies, idempotent retries, step order, refusals that change nothing,
and steps of one session never interleaving."""

from __future__ import annotations

import base64
import io
import json
import threading
from typing import Any

import cv2
import numpy as np
import pytest
from app_support import SMALL_CAMERA, new_session, oracle_observation, post_step
from fastapi.testclient import TestClient

from agent.perception import PERCEPTION_BACKENDS
from symbolic.thor import MOTION_ACTIONS

POSE = {"x": 1.0, "z": 0.5, "yaw": 90.0, "horizon": 30.0}


def _multipart(body: dict[str, Any]) -> tuple[dict[str, str], dict[str, tuple[str, bytes]]]:
    """The same step as form fields and file parts (the harness client's multipart transport)."""
    files = {
        name: (f"{name}.png", base64.b64decode(body[name]))
        for name in ("rgb", "depth", "segmentation")
        if body.get(name)
    }
    data = {
        name: value if isinstance(value, str) else json.dumps(value)
        for name, value in body.items()
        if name not in files and value is not None
    }
    return data, files


def test_a_valid_step_answers_an_action_with_its_reason_and_advances_the_session(client: TestClient) -> None:
    session_id = new_session(client)

    response = post_step(client, session_id, {**oracle_observation(), "pose": POSE, "step": 0})

    assert response.status_code == 200, response.text
    answer = response.json()
    assert answer["step"] == 0 and answer["done"] is False
    assert answer["subgoal"] == "Navigate Knife"
    assert answer["action"] in MOTION_ACTIONS  # nothing to click yet: it looks around or moves
    assert answer["x"] is None and answer["y"] is None
    assert answer["reason"]
    assert answer["plan"]["subgoals"][0]["text"] == "Navigate Knife"
    assert float(response.headers["X-Process-Time-Ms"]) > 0
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == 1


def test_multipart_and_json_give_the_same_answer(client: TestClient) -> None:
    json_id, form_id = new_session(client), new_session(client)
    body = {**oracle_observation(), "pose": POSE, "last_action_success": True, "step": 0}
    data, files = _multipart(body)

    by_json = post_step(client, json_id, body)
    by_form = client.post(f"/v1/sessions/{form_id}/step", data=data, files=files)

    assert by_form.status_code == 200, by_form.text
    assert by_form.json() == by_json.json()


MALFORMED_FORMS = [
    ("multipart/form-data", b"--x\r\n", "no boundary"),
    ("multipart/form-data; boundary=abc", b"not a form at all", "cannot be read"),
    (
        "multipart/form-data; boundary=abc",
        b"--abc\r\nContent-Type: text/plain\r\n\r\n1\r\n--abc--\r\n",
        "no ",
    ),
    (
        "multipart/form-data; boundary=abc",
        b'--abc\r\nContent-Disposition: form-data; name="step"\r\n\r\n0\r\n'
        b'--abc\r\nContent-Disposition: form-data; name="step"\r\n\r\n1\r\n--abc--\r\n',
        "step: given twice",
    ),
    (
        "multipart/form-data; boundary=abc",
        b'--abc\r\nContent-Disposition: form-data; name="held_object"\r\n\r\n\xff\xfe\r\n--abc--\r\n',
        "not UTF-8",
    ),
]


@pytest.mark.parametrize(("content_type", "body", "words"), MALFORMED_FORMS)
def test_a_malformed_form_is_a_400_naming_the_problem_and_changes_nothing(
    client: TestClient, content_type: str, body: bytes, words: str
) -> None:
    session_id = new_session(client)
    before = client.get(f"/v1/sessions/{session_id}").json()

    response = client.post(
        f"/v1/sessions/{session_id}/step", content=body, headers={"content-type": content_type}
    )

    assert response.status_code == 400, response.text
    assert response.json()["error"] == "malformed_form"
    assert words in response.json()["detail"]
    assert client.get(f"/v1/sessions/{session_id}").json() == before


def test_array_parts_give_the_answer_their_pngs_give(client: TestClient) -> None:
    """.npy file parts of the same pixels (and float32 depth) answer as the PNG parts do."""
    png_id, array_id = new_session(client), new_session(client)
    body = {**oracle_observation(), "pose": POSE, "step": 0}
    data, files = _multipart(body)
    arrays = {name: _as_npy(name, content) for name, (_, content) in files.items()}

    by_png = client.post(f"/v1/sessions/{png_id}/step", data=data, files=files)
    by_array = client.post(
        f"/v1/sessions/{array_id}/step", data={**data, "depth_encoding": "float32_m"}, files=arrays
    )

    assert by_array.status_code == 200, by_array.text
    assert by_array.json() == by_png.json()


def _as_npy(name: str, png: bytes) -> tuple[str, bytes]:
    """A PNG part as the .npy file of its pixels (RGB order; depth as float32 metres)."""
    pixels = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    if name == "rgb":
        pixels = cv2.cvtColor(pixels, cv2.COLOR_BGR2RGB)
    elif name == "depth":
        pixels = pixels.astype(np.float32) / 1000.0
    buffer = io.BytesIO()
    np.save(buffer, pixels, allow_pickle=False)
    return f"{name}.npy", buffer.getvalue()


def test_multipart_with_a_bad_pose_names_the_field(client: TestClient) -> None:
    session_id = new_session(client)
    data, files = _multipart(oracle_observation())
    data["pose"] = '{"x": 1.0}'

    response = client.post(f"/v1/sessions/{session_id}/step", data=data, files=files)

    assert response.status_code == 422
    assert response.json()["error"] == "validation_error"
    assert "pose.z" in response.json()["detail"]


def test_a_retried_step_gets_the_same_answer_and_changes_nothing(client: TestClient) -> None:
    session_id = new_session(client)
    body = {**oracle_observation(), "pose": POSE, "step": 0}
    first = post_step(client, session_id, body)
    session_after_first = client.get(f"/v1/sessions/{session_id}").json()
    trace_after_first = client.get(f"/v1/sessions/{session_id}/trace").text

    again = post_step(client, session_id, body)

    assert again.status_code == 200
    assert again.json() == first.json()
    assert client.get(f"/v1/sessions/{session_id}").json() == session_after_first
    assert client.get(f"/v1/sessions/{session_id}/trace").text == trace_after_first


def test_a_step_index_neither_next_nor_last_is_refused(client: TestClient) -> None:
    session_id = new_session(client)
    assert post_step(client, session_id, {**oracle_observation(), "step": 0}).status_code == 200
    assert post_step(client, session_id, {**oracle_observation(), "step": 1}).status_code == 200

    stale = post_step(client, session_id, {**oracle_observation(), "step": 0})
    ahead = post_step(client, session_id, {**oracle_observation(), "step": 5})

    for response in (stale, ahead):
        assert response.status_code == 409
        assert response.json()["error"] == "step_out_of_order"
        assert "expects step 2" in response.json()["detail"]
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == 2


def test_per_frame_segmentation_ids_are_declared_in_json_or_form_and_shown_in_the_trace(
    client: TestClient,
) -> None:
    json_id, form_id = new_session(client), new_session(client)
    body = {**oracle_observation(), "segmentation_ids_persistent": False}
    data, files = _multipart(body)

    assert post_step(client, json_id, body).status_code == 200
    by_form = client.post(f"/v1/sessions/{form_id}/step", data=data, files=files)
    assert by_form.status_code == 200, by_form.text
    for session_id in (json_id, form_id):
        (entry,) = [
            json.loads(line) for line in client.get(f"/v1/sessions/{session_id}/trace").text.splitlines()
        ]
        assert entry["inputs"]["segmentation_ids_persistent"] is False
    refused = post_step(
        client, new_session(client), {**oracle_observation(), "segmentation_ids_persistent": "maybe"}
    )
    assert refused.status_code == 422 and "segmentation_ids_persistent" in refused.json()["detail"]


def test_float32_depth_with_uncertainty_is_accepted(client: TestClient) -> None:
    session_id = new_session(client)
    depth = np.full((SMALL_CAMERA["height"], SMALL_CAMERA["width"]), 1.5, dtype="<f4")
    body = {
        **oracle_observation(),
        "depth": base64.b64encode(depth.tobytes()).decode(),
        "depth_encoding": "float32_m",
        "depth_uncertainty": base64.b64encode((depth * 0.1).tobytes()).decode(),
    }

    assert post_step(client, session_id, body).status_code == 200


def test_learned_perception_needs_rgb(client: TestClient) -> None:
    if "learned" not in PERCEPTION_BACKENDS:
        pytest.skip("no learned perception back-end in this build")
    created = client.post(
        "/v1/sessions",
        json={"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA, "perception": "learned"},
    )
    if created.status_code == 422:
        assert created.json()["error"] == "perception_unavailable"
        pytest.skip(f"learned perception cannot run here: {created.json()['detail']}")
    session_id = created.json()["session_id"]

    response = post_step(client, session_id, {**oracle_observation(), "rgb": None})

    assert response.status_code == 422
    assert response.json()["error"] == "missing_observation"
    assert "rgb" in response.json()["detail"]


def test_a_refused_step_leaves_the_session_and_its_trace_as_they_were(client: TestClient) -> None:
    session_id = new_session(client)
    assert post_step(client, session_id, oracle_observation()).status_code == 200
    before = (
        client.get(f"/v1/sessions/{session_id}").content,
        client.get(f"/v1/sessions/{session_id}/trace").text,
    )
    bad_legend = {**oracle_observation(), "segmentation_legend": {"9": "Knife"}}  # id 7 is in the image

    response = post_step(client, session_id, bad_legend)

    assert response.status_code == 422
    assert response.json()["error"] == "invalid_segmentation"
    assert "7" in response.json()["detail"]
    after = (
        client.get(f"/v1/sessions/{session_id}").content,
        client.get(f"/v1/sessions/{session_id}/trace").text,
    )
    assert after == before


def test_a_file_part_that_is_no_image_field_is_refused(client: TestClient) -> None:
    session_id = new_session(client)
    data, files = _multipart(oracle_observation())
    files["pose"] = ("pose.json", io.BytesIO(b"{}").getvalue())

    response = client.post(f"/v1/sessions/{session_id}/step", data=data, files=files)

    assert response.status_code == 422
    assert "pose" in response.json()["detail"]


def test_step_while_another_request_holds_the_session_answers_409(client: TestClient) -> None:
    session_id = new_session(client)
    store = client.app.state.store  # type: ignore[attr-defined]

    with store.hold(session_id, None, 1.0, write=False):
        raced = post_step(client, session_id, oracle_observation())
    after = post_step(client, session_id, oracle_observation())

    assert raced.status_code == 409
    assert raced.json()["error"] == "step_in_progress"
    assert session_id in raced.json()["detail"]
    assert after.status_code == 200


def test_concurrent_steps_of_one_session_are_serialized_or_refused(client: TestClient) -> None:
    session_id = new_session(client)
    statuses: list[int] = []
    steps: list[int] = []

    def post_steps() -> None:
        for _ in range(4):
            response = post_step(client, session_id, oracle_observation())
            statuses.append(response.status_code)
            if response.status_code == 200:
                steps.append(response.json()["step"])

    threads = [threading.Thread(target=post_steps) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert len(statuses) == 12
    assert set(statuses) <= {200, 409}, statuses
    assert sorted(steps) == list(range(len(steps)))  # each answered step got its own index, none twice
    assert client.get(f"/v1/sessions/{session_id}").json()["step"] == len(steps)
