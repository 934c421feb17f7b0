"""Bad input of every kind: status, error code, a detail naming the problem, and stored sessions unchanged."""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest
from app_support import SMALL_CAMERA, oracle_observation
from fastapi.testclient import TestClient

GOOD = {"mode": "tfd", "subgoals": "Slice Bread"}
LIVE = "{live}"  # replaced by the id of a live session
DELETED = "{deleted}"  # replaced by the id of a deleted session
FULL = "{full}"  # replaced by the id of a session whose dialogue is at the turn limit


@dataclass(frozen=True)
class Case:
    name: str
    method: str
    path: str
    status: int
    error: str
    detail_mentions: str
    json_body: Any = None
    raw_body: bytes | None = None
    headers: dict[str, str] = field(default_factory=dict)


def _step(**changes: Any) -> dict[str, Any]:
    return {**oracle_observation(), **changes}


def _nan_depth() -> str:
    depth = np.full((SMALL_CAMERA["height"], SMALL_CAMERA["width"]), 2.0, dtype="<f4")
    depth[3, 4] = np.nan
    return base64.b64encode(depth.tobytes()).decode()


CASES = [
    Case("unknown mode", "POST", "/v1/sessions", 422, "validation_error", "mode", {**GOOD, "mode": "teach"}),
    Case(
        "unknown object type",
        "POST",
        "/v1/sessions",
        422,
        "unknown_object_type",
        "Flurble",
        {**GOOD, "subgoals": "Pickup Flurble"},
    ),
    Case(
        "misspelt object type gets suggestions",
        "POST",
        "/v1/sessions",
        422,
        "unknown_object_type",
        "closest types: Knife",
        {**GOOD, "subgoals": "Navigate Knif, Pickup Knif"},
    ),
    Case(
        "unknown object in EDH history",
        "POST",
        "/v1/sessions",
        422,
        "unknown_object_type",
        "history.actions[1].oid",
        {
            "mode": "edh",
            "subgoals": "Slice Bread",
            "history": {
                "actions": [{"action_name": "Forward"}, {"action_name": "Pickup", "oid": "Spork|1|2|3"}]
            },
        },
    ),
    Case(
        "malformed JSON", "POST", "/v1/sessions", 400, "malformed_json", "JSON", raw_body=b'{"mode": "tfd",'
    ),
    Case("wrong type", "POST", "/v1/sessions", 422, "validation_error", "seed", {**GOOD, "seed": "abc"}),
    Case("negative seed", "POST", "/v1/sessions", 422, "validation_error", "seed", {**GOOD, "seed": -1}),
    Case(
        "missing mode", "POST", "/v1/sessions", 422, "validation_error", "mode", {"subgoals": "Slice Bread"}
    ),
    Case("body is a list", "POST", "/v1/sessions", 422, "validation_error", "body", [GOOD]),
    Case(
        "unknown field", "POST", "/v1/sessions", 422, "validation_error", "colour", {**GOOD, "colour": "red"}
    ),
    Case(
        "oversize body",
        "POST",
        "/v1/sessions",
        413,
        "payload_too_large",
        "bytes",
        {**GOOD, "seed": 0, "instruction": None, "dialogue": [], "subgoals": "Slice Bread, " * 8000},
    ),
    Case("unknown session", "GET", "/v1/sessions/nope", 404, "session_not_found", "nope"),
    Case("delete unknown session", "DELETE", "/v1/sessions/nope", 404, "session_not_found", "nope"),
    Case(
        "utterance to deleted session",
        "POST",
        f"/v1/sessions/{DELETED}/utterances",
        404,
        "session_not_found",
        DELETED,
        {"speaker": "Commander", "text": "hi"},
    ),
    Case(
        "oracle without subgoals",
        "POST",
        "/v1/sessions",
        422,
        "subgoals_required",
        "subgoals",
        {"mode": "tfd", "planner": "oracle"},
    ),
    Case(
        "empty subgoal list",
        "POST",
        "/v1/sessions",
        422,
        "subgoals_required",
        "subgoals",
        {"mode": "tfd", "subgoals": []},
    ),
    Case(
        "malformed subgoal text",
        "POST",
        "/v1/sessions",
        422,
        "invalid_subgoals",
        "Frobnicate",
        {**GOOD, "subgoals": "Frobnicate Bread"},
    ),
    Case(
        "subgoals of wrong type",
        "POST",
        "/v1/sessions",
        422,
        "validation_error",
        "subgoals",
        {**GOOD, "subgoals": 5},
    ),
    Case(
        "too many subgoals",
        "POST",
        "/v1/sessions",
        413,
        "too_many_subgoals",
        "21",
        {**GOOD, "subgoals": ", ".join(["Open Fridge", "Close Fridge"] * 10 + ["Open Fridge"])},
    ),
    Case(
        "camera too large",
        "POST",
        "/v1/sessions",
        422,
        "camera_too_large",
        "camera.width",
        {**GOOD, "camera": {"width": 4096, "height": 300, "hfov_deg": 60}},
    ),
    Case(
        "camera too small",
        "POST",
        "/v1/sessions",
        422,
        "validation_error",
        "camera.height",
        {**GOOD, "camera": {"width": 300, "height": 8, "hfov_deg": 60}},
    ),
    Case(
        "field of view out of range",
        "POST",
        "/v1/sessions",
        422,
        "validation_error",
        "hfov_deg",
        {**GOOD, "camera": {"width": 300, "height": 300, "hfov_deg": 200}},
    ),
    Case(
        "utterance too long at creation",
        "POST",
        "/v1/sessions",
        422,
        "utterance_too_long",
        "dialogue[0].text",
        {**GOOD, "dialogue": [{"speaker": "Commander", "text": "x" * 101}]},
    ),
    Case(
        "too many utterances",
        "POST",
        "/v1/sessions",
        413,
        "too_many_utterances",
        "6 turns",
        {**GOOD, "dialogue": [{"speaker": "Commander", "text": "hi"}] * 6},
    ),
    Case(
        "unknown speaker",
        "POST",
        f"/v1/sessions/{LIVE}/utterances",
        422,
        "validation_error",
        "speaker",
        {"speaker": "Narrator", "text": "Once upon a time"},
    ),
    Case(
        "blank utterance",
        "POST",
        f"/v1/sessions/{LIVE}/utterances",
        422,
        "validation_error",
        "text",
        {"speaker": "Commander", "text": "   "},
    ),
    Case(
        "utterance too long",
        "POST",
        f"/v1/sessions/{LIVE}/utterances",
        422,
        "utterance_too_long",
        "101 characters",
        {"speaker": "Commander", "text": "y" * 101},
    ),
    Case(
        "utterance beyond the turn limit",
        "POST",
        f"/v1/sessions/{FULL}/utterances",
        413,
        "too_many_utterances",
        "6 turns",
        {"speaker": "Driver", "text": "Done. What next?"},
    ),
    Case(
        "instruction mode without instruction",
        "POST",
        "/v1/sessions",
        422,
        "validation_error",
        "instruction",
        {"mode": "instruction", "subgoals": "Open Fridge"},
    ),
    Case(
        "history outside EDH",
        "POST",
        "/v1/sessions",
        422,
        "validation_error",
        "history",
        {**GOOD, "history": {"actions": []}},
    ),
    Case(
        "history frames do not match actions",
        "POST",
        "/v1/sessions",
        422,
        "history_mismatch",
        "history.images",
        {
            "mode": "edh",
            "subgoals": "Slice Bread",
            "history": {"actions": [{"action_name": "Forward"}], "images": []},
        },
    ),
    Case("method not allowed", "PUT", "/v1/sessions", 405, "method_not_allowed", "PUT"),
    Case("unknown route", "GET", "/v2/anything", 404, "not_found", "/v2/anything"),
    Case(
        "step to unknown session", "POST", "/v1/sessions/nope/step", 404, "session_not_found", "nope", _step()
    ),
    Case(
        "oracle step without depth",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "missing_observation",
        "depth",
        _step(depth=None),
    ),
    Case(
        "frame of the wrong size",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "invalid_image",
        "16x16",
        _step(rgb=oracle_observation(16, 16)["rgb"]),
    ),
    Case(
        "not base64",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "invalid_image",
        "base64",
        _step(rgb="@@not*b64@@"),
    ),
    Case(
        "NaN depth",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "invalid_depth",
        "NaN",
        _step(depth=_nan_depth(), depth_encoding="float32_m"),
    ),
    Case(
        "unknown type in legend",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "unknown_object_type",
        "Spork",
        _step(segmentation_legend={"7": "Spork"}),
    ),
    Case(
        "NaN in JSON pose",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        422,
        "validation_error",
        "pose.x",
        raw_body=json.dumps(_step(pose={"x": float("nan"), "z": 0.0, "yaw": 0.0, "horizon": 0.0})).encode(),
    ),
    Case(
        "malformed JSON step",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        400,
        "malformed_json",
        "at byte",
        raw_body=b'{"depth_encoding": "png16_mm", "rgb": ',
    ),
    Case(
        "step out of order",
        "POST",
        f"/v1/sessions/{LIVE}/step",
        409,
        "step_out_of_order",
        "expects step 0",
        _step(step=5),
    ),
]


@pytest.fixture
def populated(client: TestClient) -> tuple[TestClient, dict[str, str]]:
    """Three live sessions (one with a full dialogue) and the id of a deleted one."""
    live = client.post("/v1/sessions", json={**GOOD, "camera": SMALL_CAMERA}).json()["session_id"]
    other = client.post(
        "/v1/sessions",
        json={**GOOD, "dialogue": [{"speaker": "Commander", "text": "Slice the bread please."}]},
    ).json()["session_id"]
    full = client.post(
        "/v1/sessions", json={**GOOD, "dialogue": [{"speaker": "Commander", "text": "Slice it."}] * 5}
    ).json()["session_id"]
    deleted = client.post("/v1/sessions", json=GOOD).json()["session_id"]
    assert client.delete(f"/v1/sessions/{deleted}").status_code == 204
    return client, {"live": live, "other": other, "full": full, "deleted": deleted}


def _snapshot(client: TestClient, ids: dict[str, str]) -> dict[str, bytes]:
    store = client.app.state.store  # type: ignore[attr-defined]
    snapshot = {"ids": json.dumps(store.ids(None)).encode()}
    for session_id in (ids["live"], ids["other"], ids["full"]):
        snapshot[session_id] = client.get(f"/v1/sessions/{session_id}").content
    return snapshot


def test_there_are_at_least_twenty_kinds_of_bad_input() -> None:
    assert len({case.name for case in CASES}) == len(CASES) >= 20


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_bad_input_is_refused_and_changes_nothing(
    case: Case, populated: tuple[TestClient, dict[str, str]]
) -> None:
    client, ids = populated
    path = case.path.replace(LIVE, ids["live"]).replace(DELETED, ids["deleted"]).replace(FULL, ids["full"])
    before = _snapshot(client, ids)
    content = case.raw_body if case.raw_body is not None else None
    if case.json_body is not None:
        content = json.dumps(case.json_body).encode()
    headers = {"content-type": "application/json", **case.headers} if content is not None else case.headers

    response = client.request(case.method, path, content=content, headers=headers)

    assert response.status_code == case.status, response.text
    body = response.json()
    assert set(body) == {"error", "detail"}
    assert body["error"] == case.error, body
    expected = case.detail_mentions.replace(DELETED, ids["deleted"])
    assert expected in body["detail"], body["detail"]
    assert _snapshot(client, ids) == before
