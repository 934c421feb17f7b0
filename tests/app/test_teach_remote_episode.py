"""Whole EDH episodes the way TEACh's inference runner drives a RemoteModel: the real server process over
TCP, our simulator standing in for AI2-THOR, every request built as ``teach/inference/remote_model.py``
builds it (``harness.drive.client.TeachRemoteModel``) and every action executed as TEACh's runner executes it
(``harness.drive.teach_remote.run_teach_episode``: the click read as ``[y, x]``). TEACh's runner lets its step
limit be set (``max_traj_steps``); a small one keeps each episode to seconds.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import httpx
import pytest

from harness.drive.client import TeachRemoteModel
from harness.drive.generated import generated_teach_instance
from harness.drive.runner import EpisodeRun, RunnerOptions
from harness.drive.service import RunningService, running_service
from harness.drive.teach_remote import run_teach_episode
from harness.render.camera import CameraSpec
from symbolic.thor import OBJECT_ACTIONS, TEACH_DRIVER_ACTIONS, TEACH_HFOV_DEG

CAMERA = CameraSpec(300, 300, TEACH_HFOV_DEG)  # TEACh's 900 costs 9x the pixels; the protocol is the same


@pytest.fixture(scope="module")
def service() -> Iterator[RunningService]:
    with running_service() as running:
        yield running


Sent = list[httpx.Request]


def run(service: RunningService, task: str, index: int, cut: str, max_steps: int) -> tuple[EpisodeRun, Sent]:
    episode, instance = generated_teach_instance("valid_unseen", index, CAMERA, (task,), cut)
    sent: Sent = []

    def record(request: httpx.Request) -> None:
        request.read()
        sent.append(request)

    http = httpx.Client(base_url=service.base_url, timeout=120.0, event_hooks={"request": [record]})
    with TeachRemoteModel(service.base_url, http=http) as model:
        assert model.test_connection()
        outcome = run_teach_episode(
            episode, instance, model, RunnerOptions(camera=CAMERA, max_steps=max_steps)
        )
    return outcome, sent


def trace_of(service: RunningService, session_id: str) -> list[dict[str, Any]]:
    response = httpx.get(f"{service.base_url}/v1/sessions/{session_id}/trace", timeout=30.0)
    assert response.status_code == 200, response.text
    return [json.loads(line) for line in response.text.splitlines()]


def session_of(service: RunningService, session_id: str) -> dict[str, Any]:
    response = httpx.get(f"{service.base_url}/v1/sessions/{session_id}", timeout=30.0)
    assert response.status_code == 200, response.text
    return dict(response.json())


def starts(sent: Sent) -> httpx.Request:
    (start,) = [request for request in sent if request.url.path == "/start_new_edh_instance"]
    return start


def check_steps(outcome: EpisodeRun, sent: Sent, trace: list[dict[str, Any]]) -> None:
    """Each answer is the decision of the agent, click row first; prev_action absent, then the last answer."""
    steps = [request for request in sent if request.url.path == "/get_next_action"]
    assert len(steps) == len(outcome.actions) == len(trace)
    assert b'name="prev_action"' not in steps[0].content
    for request, previous in zip(steps[1:], outcome.actions, strict=False):
        coord = None if previous.x is None else [previous.y, previous.x]
        expected = json.dumps({"action": previous.action, "obj_relative_coord": coord}).encode()
        assert b'name="prev_action"\r\n\r\n' + expected in request.content
    for record, entry in zip(outcome.actions, trace, strict=True):
        assert record.action in TEACH_DRIVER_ACTIONS and record.action == entry["action"]
        if record.action in OBJECT_ACTIONS:
            # The runner clicked at x = coord[1], y = coord[0]: the agent's column and row.
            assert (record.x, record.y) == (entry["x"], entry["y"]), "obj_relative_coord must be [y, x]"
        assert entry["inputs"]["rgb"] and not entry["inputs"]["depth"] and not entry["inputs"]["segmentation"]


def test_an_edh_instance_with_history_images_runs_to_its_end(service: RunningService) -> None:
    outcome, sent = run(service, "Put All X On Y", 1, "edh1", max_steps=20)
    assert outcome.end_reason in ("stop", "step_limit", "failure_limit"), outcome.error_detail
    start = starts(sent)
    assert start.headers["content-type"].startswith("multipart/form-data")
    assert start.content.count(b'name="edh_history_images"; filename="history') == 7
    session = session_of(service, outcome.session_id)
    assert (session["mode"], session["perception"], session["planner"]) == ("edh", "learned", "model")
    assert (session["camera"]["width"], session["camera"]["height"]) == (CAMERA.width, CAMERA.height)
    assert [s["text"] for s in session["history_subgoals"]] == [
        "Navigate Cup",
        "Pickup Cup",
        "Navigate DiningTable",
        "Place DiningTable",
    ]
    assert session["step"] == len(outcome.actions)
    check_steps(outcome, sent, trace_of(service, outcome.session_id))


def test_an_edh_instance_without_history_images_clicks_row_first(service: RunningService) -> None:
    """The first EDH cut has no history: the start is urlencoded, the first frame sets the camera, and this
    episode's agent clicks (Open Cabinet) within its first steps."""
    outcome, sent = run(service, "Water Plant", 0, "edh0", max_steps=8)
    assert outcome.end_reason in ("stop", "step_limit", "failure_limit"), outcome.error_detail
    assert starts(sent).headers["content-type"] == "application/x-www-form-urlencoded"
    session = session_of(service, outcome.session_id)
    assert (session["camera"]["width"], session["camera"]["height"]) == (CAMERA.width, CAMERA.height)
    clicks = [record for record in outcome.actions if record.action in OBJECT_ACTIONS]
    assert clicks, (
        "this episode was chosen because its agent clicks early (Open Cabinet at step 0); if the agent no "
        f"longer does, pick an episode that does. Actions: {[r.action for r in outcome.actions]}"
    )
    check_steps(outcome, sent, trace_of(service, outcome.session_id))
