"""No input makes the service answer 5xx: hypothesis sends session and step bodies with huge, NaN,
negative and wrongly typed numbers, odd strings and legend keys, against the real app."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest
from app_support import SMALL_CAMERA, oracle_observation
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.main import create_app
from app.settings import Settings

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([0, -1, 1e-300, 1e308, 2**31, 2**32, 2**63, 2**64, 10**20]),
)
ANYTHING = st.one_of(
    NUMBERS, st.text(max_size=20), st.none(), st.booleans(), st.lists(st.integers(), max_size=3)
)
MAYBE_NUMBER = st.one_of(NUMBERS, ANYTHING)
LEGEND_KEYS = st.one_of(
    st.integers(min_value=-(10**25), max_value=10**25).map(str),
    st.text(max_size=12),
    st.sampled_from(["7", "0", "-1", "1e3", " 7", "100000000000000000000", "4294967296"]),
)
LEGEND_TYPES = st.one_of(st.sampled_from(["Knife", "CounterTop", "knife", "Toaster"]), st.text(max_size=10))
PROPERTY_SETTINGS = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    app = create_app(Settings(log_level="critical", max_sessions=1000, max_image_side=1024))
    with TestClient(app, raise_server_exceptions=False) as test_client:
        yield test_client


@pytest.fixture(scope="module")
def session_id(client: TestClient) -> str:
    body = {"mode": "tfd", "subgoals": "Slice Bread", "camera": SMALL_CAMERA}
    response = client.post("/v1/sessions", json=body)
    assert response.status_code == 201, response.text
    return str(response.json()["session_id"])


def _post(client: TestClient, path: str, body: Any) -> Any:
    """JSON as Python's json writes it: NaN and Infinity included, as a careless client would send."""
    return client.post(path, content=json.dumps(body), headers={"content-type": "application/json"})


camera_bodies = st.fixed_dictionaries(
    {},
    optional={
        "width": MAYBE_NUMBER,
        "height": MAYBE_NUMBER,
        "hfov_deg": MAYBE_NUMBER,
        "height_m": MAYBE_NUMBER,
    },
)
session_bodies = st.fixed_dictionaries(
    {"mode": st.one_of(st.sampled_from(["tfd", "edh", "tatc", "instruction"]), st.text(max_size=8))},
    optional={
        "camera": st.one_of(camera_bodies, ANYTHING),
        "subgoals": st.one_of(st.sampled_from(["Slice Bread", "Pickup Knife"]), ANYTHING),
        "planner": st.sampled_from(["oracle", "model", "nope"]),
        "seed": MAYBE_NUMBER,
        "perception": st.sampled_from(["oracle", "learned", "x"]),
        "navigator": st.sampled_from(["fmm", "vin", "x"]),
        "history": st.fixed_dictionaries(
            {
                "actions": st.lists(
                    st.fixed_dictionaries(
                        {"action_name": st.text(min_size=1, max_size=10)},
                        optional={
                            "x": MAYBE_NUMBER,
                            "y": MAYBE_NUMBER,
                            "action_id": MAYBE_NUMBER,
                            "time_start": MAYBE_NUMBER,
                        },
                    ),
                    max_size=3,
                )
            },
            optional={
                "start_pose": st.fixed_dictionaries(
                    {"x": MAYBE_NUMBER, "z": MAYBE_NUMBER, "yaw": MAYBE_NUMBER, "horizon": MAYBE_NUMBER}
                )
            },
        ),
        "dialogue": st.lists(
            st.fixed_dictionaries(
                {"speaker": st.sampled_from(["Commander", "Driver", "x"]), "text": st.text(max_size=30)}
            ),
            max_size=3,
        ),
    },
)
pose_bodies = st.fixed_dictionaries(
    {"x": MAYBE_NUMBER, "z": MAYBE_NUMBER, "yaw": MAYBE_NUMBER, "horizon": MAYBE_NUMBER}
)
step_changes = st.fixed_dictionaries(
    {},
    optional={
        "pose": st.one_of(pose_bodies, ANYTHING),
        "segmentation_legend": st.one_of(st.dictionaries(LEGEND_KEYS, LEGEND_TYPES, max_size=3), ANYTHING),
        "step": MAYBE_NUMBER,
        "last_action_success": ANYTHING,
        "depth_encoding": st.one_of(st.sampled_from(["png16_mm", "float32_m"]), st.text(max_size=8)),
        "held_object": st.one_of(LEGEND_TYPES, ANYTHING),
        "segmentation_ids_persistent": ANYTHING,
        "rgb": st.one_of(st.text(max_size=20), st.none()),
    },
)


@PROPERTY_SETTINGS
@given(body=session_bodies)
def test_no_session_body_answers_5xx(client: TestClient, body: dict[str, Any]) -> None:
    response = _post(client, "/v1/sessions", body)
    assert response.status_code < 500, (body, response.text)
    if response.status_code >= 400:
        assert set(response.json()) == {"error", "detail"}


@PROPERTY_SETTINGS
@given(changes=step_changes)
def test_no_step_body_answers_5xx(client: TestClient, session_id: str, changes: dict[str, Any]) -> None:
    body = {**oracle_observation(), **changes}
    response = _post(client, f"/v1/sessions/{session_id}/step", body)
    assert response.status_code < 500, (changes, response.text)
    if response.status_code >= 400:
        assert set(response.json()) == {"error", "detail"}
