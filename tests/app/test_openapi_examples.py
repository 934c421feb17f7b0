"""The examples /docs shows are true: the create and step examples work as sent (Swagger UI's "Try it out"),
the documented plan is the one the service answers, and each route's error statuses show the codes that
route really answers."""

from __future__ import annotations

import base64
import io
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from app.api.responses import ERROR_EXAMPLES, ROUTE_ERRORS
from symbolic.thor import TEACH_DRIVER_ACTIONS

STEP = ("post", "/v1/sessions/{session_id}/step")


def _openapi(client: TestClient) -> dict[str, Any]:
    response = client.get("/openapi.json")
    assert response.status_code == 200
    return dict(response.json())


def _example(openapi: dict[str, Any], schema: str) -> dict[str, Any]:
    examples = openapi["components"]["schemas"][schema]["examples"]
    assert len(examples) == 1, schema
    return dict(examples[0])


def _decoded_png(data: str) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))))


def _error_examples(openapi: dict[str, Any], method: str, path: str, status: int) -> dict[str, Any]:
    response = openapi["paths"][path][method]["responses"][str(status)]
    return dict(response["content"]["application/json"].get("examples", {}))


def test_the_create_and_step_examples_work_as_documented(client: TestClient) -> None:
    openapi = _openapi(client)
    create, step = _example(openapi, "SessionCreate"), _example(openapi, "StepRequest")
    documented_plan = openapi["components"]["schemas"]["SessionPublic"]["properties"]["plan"]["examples"][0]

    created = client.post("/v1/sessions", json=create)
    assert created.status_code == 201, created.text
    session_id = created.json()["session_id"]
    first = client.post(f"/v1/sessions/{session_id}/step", json=step)
    again = client.post(f"/v1/sessions/{session_id}/step", json=step)  # "Execute" pressed twice
    skipped = client.post(f"/v1/sessions/{session_id}/step", json={**step, "step": 5})

    assert created.json()["plan"] == documented_plan
    assert len(documented_plan["subgoals"]) == 4 and documented_plan["repair_log"]
    assert first.status_code == 200, first.text
    assert first.json()["action"] in TEACH_DRIVER_ACTIONS
    assert again.status_code == 200 and again.json() == first.json()
    assert skipped.status_code == 409
    assert skipped.json()["error"] in _error_examples(openapi, *STEP, 409)


def test_the_step_examples_images_are_real_frames_of_the_example_camera(client: TestClient) -> None:
    openapi = _openapi(client)
    camera = _example(openapi, "SessionCreate")["camera"]
    step = _example(openapi, "StepRequest")
    H, W = camera["height"], camera["width"]

    rgb = _decoded_png(step["rgb"])
    depth_mm = _decoded_png(step["depth"])
    ids = _decoded_png(step["segmentation"])

    assert rgb.shape == (H, W, 3) and rgb.dtype == np.uint8
    assert depth_mm.shape == (H, W) and depth_mm.min() > 0  # every pixel a reading, in millimetres
    assert ids.shape == (H, W)
    assert {str(i) for i in np.unique(ids)} == set(step["segmentation_legend"])
    assert len({tuple(c) for c in rgb.reshape(-1, 3)}) == len(step["segmentation_legend"])  # one colour each
    properties = openapi["components"]["schemas"]["StepRequest"]["properties"]
    for field in ("rgb", "depth", "segmentation"):
        assert properties[field]["examples"] == [step[field]], field  # no "iVBORw0KGgo..." stubs left


def test_error_statuses_show_the_codes_each_route_answers(client: TestClient) -> None:
    openapi = _openapi(client)

    def codes(method: str, path: str, status: int) -> set[str]:
        return set(_error_examples(openapi, method, path, status))

    assert codes(*STEP, 404) == {"session_not_found"}
    assert codes("post", "/get_next_action", 404) == {"edh_instance_not_started"}
    assert codes(*STEP, 409) == {"step_in_progress", "lease_lost", "step_out_of_order"}
    assert codes("post", "/v1/sessions/{session_id}/utterances", 409) == {"step_in_progress", "lease_lost"}
    assert codes("get", "/v1/sessions/{session_id}", 404) == {"session_not_found"}
    assert {"too_many_subgoals", "too_many_utterances", "payload_too_large"} <= codes(
        "post", "/v1/sessions", 413
    )
    assert {"invalid_image", "invalid_depth", "missing_observation"} <= codes(*STEP, 422)
    assert codes("post", "/v1/sessions", 429) == {"rate_limited", "too_many_sessions"}
    assert codes("get", "/readyz", 503) == {"not_ready", "store_unavailable"}


def test_each_example_carries_its_own_code_under_its_status(client: TestClient) -> None:
    openapi = _openapi(client)
    shown = 0
    for path, item in openapi["paths"].items():
        for method, operation in item.items():
            for status, response in operation["responses"].items():
                for code, example in (
                    response.get("content", {}).get("application/json", {}).get("examples", {}).items()
                ):
                    assert example["value"]["error"] == code, (method, path, status)
                    assert str(ERROR_EXAMPLES[code].status) == status, (method, path, code)
                    assert example["value"]["detail"] and example["summary"], (method, path, code)
                    shown += 1
    assert shown > 100


def test_every_operation_that_documents_errors_names_the_codes_behind_them(client: TestClient) -> None:
    openapi = _openapi(client)
    documented = {
        (method, path)
        for path, item in openapi["paths"].items()
        for method, operation in item.items()
        if any(status.startswith(("4", "5")) for status in operation["responses"])
    }

    assert documented - set(ROUTE_ERRORS) == set(), "add the new operations' error codes to ROUTE_ERRORS"
    assert set(ROUTE_ERRORS) - documented == set(), "ROUTE_ERRORS names operations the service lacks"


@pytest.mark.parametrize(
    ("method", "path", "request_kwargs", "status"),
    [
        ("post", "/v1/sessions/{session_id}/step", {"json": {}}, 404),
        ("get", "/v1/sessions/{session_id}", {}, 404),
        ("post", "/v1/sessions", {"json": {"mode": "tfd", "subgoals": "Slice Bred"}}, 422),
        (
            "post",
            "/v1/sessions",
            {"content": b'{"mode": "tfd"', "headers": {"content-type": "application/json"}},
            400,
        ),
        ("post", "/get_next_action", {"json": {}}, 415),
        (
            "post",
            "/get_next_action",
            {"data": {"edh_name": "never-started"}, "files": {"img": ("a.jpg", b"x")}},
            404,
        ),
    ],
)
def test_a_real_error_answer_is_one_of_the_documented_examples(
    client: TestClient, method: str, path: str, request_kwargs: dict[str, Any], status: int
) -> None:
    openapi = _openapi(client)

    response = client.request(method, path.replace("{session_id}", "0" * 32), **request_kwargs)

    assert response.status_code == status, response.text
    assert response.json()["error"] in _error_examples(openapi, method, path, status)
