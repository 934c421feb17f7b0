"""API keys, ownership and quotas on the real app: with keys configured every route but health needs one, a
session (and a TEACh ``edh_name``) belongs to the key that made it, and each key has its own session cap and
request rate, answered 429 with Retry-After."""

from __future__ import annotations

import base64
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from app_support import SMALL_CAMERA, oracle_observation
from fastapi.testclient import TestClient
from test_teach_api import EDH, frame, remote, start

from app.keys import KeyConfigError, KeyRing, hash_key, read_key_file

ALICE, BOB = "alice-secret-key", "bob-secret-key"
KEYS = f"alice:{hash_key(ALICE)},bob:{hash_key(BOB)}"


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


def _create(client: TestClient, key: str) -> Any:
    return client.post(
        "/v1/sessions",
        json={"mode": "tfd", "planner": "oracle", "subgoals": "Open Fridge", "camera": SMALL_CAMERA},
        headers=bearer(key),
    )


@pytest.fixture
def keyed(make_client: Callable[..., TestClient]) -> TestClient:
    return make_client(api_keys=KEYS, max_sessions=10)


def test_without_a_valid_key_only_health_answers(keyed: TestClient) -> None:
    created = _create(keyed, ALICE).json()["session_id"]
    for method, path in [
        ("POST", "/v1/sessions"),
        ("GET", "/v1/sessions"),
        ("GET", f"/v1/sessions/{created}"),
        ("DELETE", f"/v1/sessions/{created}"),
        ("POST", "/start_new_edh_instance"),
    ]:
        for headers in ({}, bearer("not-a-key"), {"Authorization": "Basic !!!"}):
            response = keyed.request(method, path, headers=headers)
            assert response.status_code == 401, (method, path, headers, response.text)
            assert response.json()["error"] == "unauthorized"
            assert response.headers["WWW-Authenticate"].startswith("Bearer")
    assert keyed.get("/healthz").status_code == 200 and keyed.get("/readyz").status_code in (200, 503)
    assert keyed.get(f"/v1/sessions/{created}", headers=bearer(ALICE)).status_code == 200


def test_every_way_of_sending_the_key_works(keyed: TestClient) -> None:
    basic_user = base64.b64encode(f"{ALICE}:".encode()).decode()  # RemoteModel with KEY@host:port
    basic_password = base64.b64encode(f"anyone:{ALICE}".encode()).decode()
    for headers in (
        bearer(ALICE),
        {"X-API-Key": ALICE},
        {"Authorization": f"Basic {basic_user}"},
        {"Authorization": f"Basic {basic_password}"},
    ):
        assert keyed.get("/v1/sessions", headers=headers).status_code == 200, headers


def test_another_keys_session_is_not_found_and_unchanged(keyed: TestClient) -> None:
    session_id = _create(keyed, ALICE).json()["session_id"]
    before = keyed.get(f"/v1/sessions/{session_id}", headers=bearer(ALICE)).json()
    step = {**oracle_observation(), "step": 0}

    attempts = [
        keyed.get(f"/v1/sessions/{session_id}", headers=bearer(BOB)),
        keyed.get(f"/v1/sessions/{session_id}/trace", headers=bearer(BOB)),
        keyed.get(f"/v1/sessions/{session_id}/map.png", headers=bearer(BOB)),
        keyed.post(f"/v1/sessions/{session_id}/step", json=step, headers=bearer(BOB)),
        keyed.post(
            f"/v1/sessions/{session_id}/utterances",
            json={"speaker": "Commander", "text": "open the fridge"},
            headers=bearer(BOB),
        ),
        keyed.delete(f"/v1/sessions/{session_id}", headers=bearer(BOB)),
    ]

    for response in attempts:
        assert response.status_code == 404, response.text
        assert response.json()["error"] == "session_not_found"
    assert keyed.get("/v1/sessions", headers=bearer(BOB)).json() == {"session_ids": []}
    assert keyed.get("/v1/sessions", headers=bearer(ALICE)).json() == {"session_ids": [session_id]}
    assert keyed.get(f"/v1/sessions/{session_id}", headers=bearer(ALICE)).json() == before


def test_each_key_runs_its_own_teach_instance_of_one_edh_name(keyed: TestClient) -> None:
    keyed.headers.update(bearer(ALICE))
    alices = start(keyed, name="edh/shared.json")
    action, coord = remote(keyed).get_next_action(frame(0), EDH, None, "img_1.jpeg", "edh/shared.json")
    keyed.headers.update(bearer(BOB))
    bobs = start(keyed, name="edh/shared.json")  # the same public file name, another key
    keyed.headers.update(bearer(ALICE))
    prev = {"action": action, "obj_relative_coord": coord}
    remote(keyed).get_next_action(frame(1), EDH, prev, "img_2.jpeg", "edh/shared.json")

    assert alices["session_id"] != bobs["session_id"]
    assert keyed.get(f"/v1/sessions/{alices['session_id']}").json()["step"] == 2
    assert keyed.get(f"/v1/sessions/{bobs['session_id']}", headers=bearer(BOB)).json()["step"] == 0
    assert keyed.get(f"/v1/sessions/{bobs['session_id']}").status_code == 404


def test_a_key_at_its_session_cap_gets_429_and_others_still_create(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(api_keys=KEYS, max_sessions=10, max_sessions_per_key=2)
    assert [_create(client, ALICE).status_code for _ in range(2)] == [201, 201]

    refused = _create(client, ALICE)

    assert refused.status_code == 429 and refused.json()["error"] == "too_many_sessions"
    assert 1 <= int(refused.headers["Retry-After"]) <= 60
    assert "JARVIS_MAX_SESSIONS_PER_KEY" in refused.json()["detail"]
    assert _create(client, BOB).status_code == 201
    assert len(client.get("/v1/sessions", headers=bearer(ALICE)).json()["session_ids"]) == 2


def test_a_full_store_says_when_to_retry_even_without_keys(make_client: Callable[..., TestClient]) -> None:
    client = make_client(max_sessions=1)
    body = {"mode": "tfd", "planner": "oracle", "subgoals": "Open Fridge", "camera": SMALL_CAMERA}
    assert client.post("/v1/sessions", json=body).status_code == 201

    refused = client.post("/v1/sessions", json=body)

    assert refused.status_code == 429 and int(refused.headers["Retry-After"]) >= 1


def test_a_key_over_its_rate_gets_429_with_retry_after_and_others_do_not(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(api_keys=KEYS, rate_per_key_per_s=0.5, rate_burst_per_key=3)
    statuses = [client.get("/v1/sessions", headers=bearer(ALICE)).status_code for _ in range(4)]
    limited = client.get("/v1/sessions", headers=bearer(ALICE))

    assert statuses == [200, 200, 200, 429]
    assert limited.json()["error"] == "rate_limited" and int(limited.headers["Retry-After"]) == 2
    assert client.get("/v1/sessions", headers=bearer(BOB)).status_code == 200
    assert client.get("/healthz").status_code == 200  # health is never limited


def test_a_keys_file_sets_each_keys_quota(tmp_path: Path, make_client: Callable[..., TestClient]) -> None:
    keys_file = tmp_path / "keys.jsonl"
    keys_file.write_text(
        "# lab keys\n"
        + json.dumps({"name": "lab-a", "sha256": hash_key(ALICE), "max_sessions": 1})
        + "\n\n"
        + json.dumps({"name": "lab-b", "sha256": hash_key(BOB)})
        + "\n"
    )
    client = make_client(api_keys_file=keys_file, max_sessions_per_key=5)

    assert [_create(client, ALICE).status_code for _ in range(2)] == [201, 429]
    assert [_create(client, BOB).status_code for _ in range(2)] == [201, 201]


@pytest.mark.parametrize(
    ("line", "complaint"),
    [
        ('{"name": "a", "sha256": "plain-key"}', "SHA-256"),
        ('{"name": "a b", "sha256": "' + "0" * 64 + '"}', "key name"),
        ('{"name": "a", "sha256": "' + "0" * 64 + '", "max_sessions": -1}', "positive"),
        ('{"name": "a", "sha": "x"}', "unknown fields"),
        ("not json", "not JSON"),
    ],
)
def test_a_bad_keys_file_is_refused_naming_the_line(tmp_path: Path, line: str, complaint: str) -> None:
    keys_file = tmp_path / "keys.jsonl"
    keys_file.write_text(line + "\n")
    with pytest.raises(KeyConfigError, match=complaint) as error:
        read_key_file(keys_file)
    assert f"{keys_file}:1" in str(error.value)


def test_the_same_key_twice_is_refused() -> None:
    with pytest.raises(KeyConfigError, match="same key"):
        KeyRing.configured(f"a:{hash_key(ALICE)},b:{hash_key(ALICE)}", None)


def test_the_key_maker_prints_a_key_its_entry_accepts() -> None:
    made = subprocess.run(
        [sys.executable, "-m", "app.keys", "new", "lab-c"], capture_output=True, text=True, check=True
    ).stdout
    lines = dict(line.split(": ", 1) for line in made.strip().splitlines())
    secret = lines["key (give it to the client; it is not stored anywhere)"]
    ring = KeyRing.configured(lines["JARVIS_API_KEYS entry"], None)

    identified = ring.identify(secret)
    assert identified is not None and identified.name == "lab-c"
    assert secret not in lines["JARVIS_API_KEYS entry"]
