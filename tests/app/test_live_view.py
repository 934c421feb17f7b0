"""The live view: reads served from the last completed change while a step holds the session, the event
stream (ids, resume, heartbeat, end), keys, TEACh sessions, and views shared by workers through Redis.

The event stream never ends by itself, which FastAPI's TestClient cannot read (it waits for the whole
answer), so those tests run the real app under uvicorn in a thread and read the stream over TCP.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import httpx
import redis
from app_support import SMALL_CAMERA, oracle_observation, serving
from fastapi import FastAPI
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from harness.drive.client import TeachRemoteModel

SESSION = {"mode": "tfd", "planner": "oracle", "subgoals": "Slice Bread", "camera": SMALL_CAMERA}
QUIET: dict[str, Any] = {"log_level": "warning", "preload_models": False, "session_lock_timeout_s": 0.2}


# ---- helpers -----------------------------------------------------------------------------------------------


@contextmanager
def served(app: FastAPI) -> Iterator[httpx.Client]:
    """The app under uvicorn on a free port in a thread; an HTTP client pointed at it."""
    # Generous: the TEACh test loads the learned perception networks on its first step.
    with serving(app) as base_url, httpx.Client(base_url=base_url, timeout=120.0) as http:
        yield http


class EventReader:
    """The blocks of one server-sent event stream, read one at a time."""

    def __init__(self, response: httpx.Response) -> None:
        self.response = response
        self._lines = response.iter_lines()

    def next(self) -> dict[str, Any]:
        """The next block: {"id", "event", "data"} (data parsed), or {"comment": text}; {"end": True} when
        the stream ended."""
        block: dict[str, Any] = {}
        for line in self._lines:
            if line == "":
                if block:
                    return block
                continue
            if line.startswith(":"):
                block["comment"] = line[1:].strip()
                continue
            field, _, value = line.partition(": ")
            block[field] = json.loads(value) if field == "data" else value
        return {"end": True}

    def next_event(self) -> dict[str, Any]:
        """The next block that is an event (skipping ``retry`` and heartbeats)."""
        while True:
            block = self.next()
            if "event" in block or "end" in block:
                return block


@contextmanager
def events(http: httpx.Client, session_id: str, **headers: str) -> Iterator[EventReader]:
    with http.stream("GET", f"/v1/sessions/{session_id}/events", headers=headers) as response:
        assert response.status_code == 200, response.read()
        assert response.headers["content-type"].startswith("text/event-stream")
        yield EventReader(response)


def _create(http: httpx.Client | TestClient, **headers: str) -> str:
    response = http.post("/v1/sessions", json=SESSION, headers=headers)
    assert response.status_code == 201, response.text
    return str(response.json()["session_id"])


def _step(http: httpx.Client | TestClient, session_id: str, **headers: str) -> dict[str, Any]:
    response = http.post(f"/v1/sessions/{session_id}/step", json=oracle_observation(), headers=headers)
    assert response.status_code == 200, response.text
    return dict(response.json())


# ---- reads never wait for a step -------------------------------------------------------------------------


def test_reads_during_a_step_answer_at_once_with_the_last_completed_state(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client()
    session_id = _create(client)
    _step(client, session_id)
    store = client.app.state.store  # type: ignore[attr-defined]

    with store.hold(session_id, None, 1.0, write=True):  # a step in progress holds it so
        started = time.monotonic()
        session = client.get(f"/v1/sessions/{session_id}")
        trace = client.get(f"/v1/sessions/{session_id}/trace")
        picture = client.get(f"/v1/sessions/{session_id}/map.png")
        waited = time.monotonic() - started
        raced = client.post(f"/v1/sessions/{session_id}/step", json=oracle_observation())

    assert session.status_code == 200 and session.json()["step"] == 1
    assert trace.status_code == 200 and len(trace.text.splitlines()) == 1
    assert picture.status_code == 200 and picture.content.startswith(b"\x89PNG")
    assert waited < 0.2, f"reads took {waited:.2f} s: they waited for the held session"
    assert raced.status_code == 409 and raced.json()["error"] == "step_in_progress"  # writes still serialize


def test_a_read_shows_each_completed_change(client: TestClient) -> None:
    session_id = _create(client)
    first_map = client.get(f"/v1/sessions/{session_id}/map.png").content
    _step(client, session_id)
    client.post(f"/v1/sessions/{session_id}/utterances", json={"speaker": "Commander", "text": "Hurry."})

    session = client.get(f"/v1/sessions/{session_id}").json()
    assert session["step"] == 1
    assert session["dialogue"][-1]["text"] == "Hurry."
    assert client.get(f"/v1/sessions/{session_id}/map.png").content != first_map
    assert [
        json.loads(line)["step"] for line in client.get(f"/v1/sessions/{session_id}/trace").text.splitlines()
    ] == [0]


def test_a_view_keeps_showing_its_own_state_after_the_session_steps_on(client: TestClient) -> None:
    store = client.app.state.store  # type: ignore[attr-defined]
    alone, moving_on = _create(client), _create(client)
    _step(client, alone)
    _step(client, moving_on)
    published = asyncio.run(store.view(moving_on, None, touch=False))  # not drawn yet
    for _ in range(3):
        _step(client, moving_on)

    assert published.map_png() == client.get(f"/v1/sessions/{alone}/map.png").content
    assert published.map_png() != client.get(f"/v1/sessions/{moving_on}/map.png").content


# ---- the pages -------------------------------------------------------------------------------------------


def test_the_pages_and_their_script_are_served_without_any_other_host(client: TestClient) -> None:
    listing = client.get("/v1/view")
    page = client.get("/v1/sessions/abc/view")
    script = client.get("/v1/view/live.js")

    assert listing.status_code == 200 and listing.headers["content-type"].startswith("text/html")
    assert page.status_code == 200 and 'id="map"' in page.text and 'id="trace"' in page.text
    assert script.status_code == 200 and "Last-Event-ID" in script.text
    for html in (listing.text, page.text):
        assert "http://" not in html and "https://" not in html, "a page must load nothing from another host"


# ---- the event stream ------------------------------------------------------------------------------------


def test_the_stream_sends_each_change_resumes_beats_and_ends_with_the_session() -> None:
    app = create_app(Settings(**QUIET, live_poll_s=0.02, live_heartbeat_s=0.3))
    with served(app) as http:
        session_id = _create(http)
        with events(http, session_id) as stream:
            created = stream.next_event()
            answer = _step(http, session_id)
            stepped = stream.next_event()

        assert created["event"] == "view" and created["id"] == "0.0"
        assert created["data"]["frame"] is None and created["data"]["trace"] == []
        assert stepped["id"] == "1.0"
        data = stepped["data"]
        assert data["step"] == 1 and data["trace"][-1]["action"] == answer["action"]
        assert data["trace"][-1]["reason"] == answer["reason"]
        assert data["frame"]["step"] == 0 and data["frame"]["action"] == answer["action"]
        assert data["map_png"] and data["frame"]["jpeg"]
        assert "slice-needs-knife" in [e["rule"] for e in data["session"]["plan"]["repair_log"]]
        assert data["progress"]["subgoals"] == 4 and data["progress"]["goal_conditions"] is None

        # Reconnecting with the last id: nothing old again, a heartbeat while quiet, then the next change.
        with events(http, session_id, **{"Last-Event-ID": "1.0"}) as stream:
            assert stream.next() == {"retry": "2000"}
            assert stream.next() == {"comment": "keep-alive"}
            http.post(f"/v1/sessions/{session_id}/utterances", json={"speaker": "Driver", "text": "On it."})
            spoken = stream.next_event()
            assert spoken["id"] == "1.1" and spoken["data"]["session"]["dialogue"][-1]["text"] == "On it."
            assert spoken["data"]["frame"]["step"] == 0, "an utterance keeps the last step's frame"
            http.delete(f"/v1/sessions/{session_id}")
            gone = stream.next_event()
            assert gone["event"] == "gone" and gone["data"]["session_id"] == session_id
            assert stream.next() == {"end": True}

        missing = http.get(f"/v1/sessions/{session_id}/events")
        assert missing.status_code == 404 and missing.json()["error"] == "session_not_found"


def test_the_stream_and_reads_respect_api_keys() -> None:
    keys = ",".join(f"{name}:{hashlib.sha256(secret.encode()).hexdigest()}" for name, secret in KEYS.items())
    app = create_app(Settings(**QUIET, api_keys=keys, live_poll_s=0.02))
    alice = {"Authorization": f"Bearer {KEYS['alice']}"}
    bob = {"X-API-Key": KEYS["bob"]}
    with served(app) as http:
        session_id = _create(http, **alice)
        assert http.get(f"/v1/sessions/{session_id}/view").status_code == 200  # the page shell: no data
        assert http.get(f"/v1/sessions/{session_id}/events").status_code == 401
        assert http.get(f"/v1/sessions/{session_id}/events", headers=bob).status_code == 404
        assert http.get(f"/v1/sessions/{session_id}/map.png", headers=bob).status_code == 404
        assert http.get("/v1/sessions", headers=bob).json()["session_ids"] == []
        with events(http, session_id, **alice) as stream:
            assert stream.next_event()["data"]["session"]["session_id"] == session_id


KEYS = {"alice": "alice-secret-key-0123456789", "bob": "bob-secret-key-0123456789"}


def test_a_teach_session_is_watched_like_any_other() -> None:
    app = create_app(Settings(**QUIET, live_poll_s=0.02))
    instance = {"instance_id": "g1.edh0", "dialog_history": [["Commander", "Pick up the mug."]]}
    with served(app) as http:
        teach = TeachRemoteModel("", http=http)
        started = teach.start_new_edh_instance(instance, None, "g1.edh0")
        session_id = started["session_id"]
        with events(http, session_id) as stream:
            assert stream.next_event()["data"]["frame"] is None
            action, coord = teach.get_next_action(_teach_frame(), instance, None, "img_1.jpeg", "g1.edh0")
            data = stream.next_event()["data"]

    assert data["session"]["mode"] == "edh" and data["session"]["perception"] == "learned"
    assert data["frame"]["action"] == action and data["trace"][-1]["action"] == action
    if coord is not None:
        assert [data["frame"]["y"], data["frame"]["x"]] == coord


def _teach_frame() -> Any:
    import numpy as np
    from PIL import Image

    pixels = np.full((96, 96, 3), 120, dtype=np.uint8)
    pixels[48:, :] = (150, 130, 100)
    pixels[30:50, 30:60] = (200, 40, 40)
    return Image.fromarray(pixels)


# ---- several workers: the view goes through Redis -------------------------------------------------------


def test_a_worker_serves_the_view_another_worker_stored_while_a_third_holds_the_session(
    redis_url: str, redis_prefix: str
) -> None:
    settings = Settings(**QUIET, store=redis_url, store_prefix=redis_prefix, live_poll_s=0.02)
    stepping, watching = create_app(settings), create_app(settings)
    with served(stepping) as one, served(watching) as other:
        session_id = _create(one)
        with events(other, session_id) as stream:
            assert stream.next_event()["id"] == "0.0"
            answer = _step(one, session_id)
            seen = stream.next_event()
        assert seen["id"] == "1.0" and seen["data"]["trace"][-1]["action"] == answer["action"]
        assert seen["data"]["frame"]["step"] == 0

        store = stepping.state.store  # a step in progress on the first worker holds the lease
        with store.hold(session_id, None, 5.0, write=True):
            started = time.monotonic()
            session = other.get(f"/v1/sessions/{session_id}")
            trace = other.get(f"/v1/sessions/{session_id}/trace")
            picture = other.get(f"/v1/sessions/{session_id}/map.png")
            waited = time.monotonic() - started
        assert session.status_code == 200 and session.json()["step"] == 1
        assert [json.loads(line)["action"] for line in trace.text.splitlines()] == [answer["action"]]
        assert picture.status_code == 200 and picture.content.startswith(b"\x89PNG")
        assert waited < 1.0, f"reads on another worker took {waited:.2f} s: they waited for the lease"

        other.delete(f"/v1/sessions/{session_id}")
        assert one.get(f"/v1/sessions/{session_id}/trace").status_code == 404


def test_with_redis_a_step_nobody_watches_stores_no_frame_and_a_watched_one_does(
    redis_url: str, redis_prefix: str
) -> None:
    """Encoding the frame cost every step 0.4-0.9 ms for a page that is mostly not open: an unwatched step
    drops the stored frame (so no page shows a stale one as current), an open page's steps store theirs."""
    settings = Settings(**QUIET, store=redis_url, store_prefix=redis_prefix, live_poll_s=0.02)
    app = create_app(settings)
    frame_stored = redis.Redis.from_url(redis_url).hexists
    with served(app) as http:
        session_id = _create(http)
        _step(http, session_id)
        unwatched = frame_stored(f"{redis_prefix}:s:{session_id}", "frame")
        with events(http, session_id) as stream:
            opened = stream.next_event()
            answer = _step(http, session_id)
            watched = stream.next_event()

    assert not unwatched and opened["id"] == "1.0" and opened["data"]["frame"] is None
    assert watched["id"] == "2.0" and watched["data"]["frame"]["step"] == 1
    assert watched["data"]["frame"]["action"] == answer["action"] and watched["data"]["frame"]["jpeg"]
