"""TEACh's RemoteModel routes on the real app (TestClient): forms built exactly as RemoteModel builds them.

``harness.drive.client.TeachRemoteModel`` mirrors TEACh's ``teach/inference/remote_model.py`` request for
request (fields dropped when None, as ``requests`` does; JPEG files saved with PIL's defaults); the error
cases post hand-made forms. Frames are small synthetic pictures: these tests are about the protocol, the
whole-episode test in ``test_teach_remote_episode.py`` drives the simulator.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image
from prometheus_client.parser import text_string_to_metric_families

from harness.drive.client import TeachRemoteModel
from symbolic.thor import CAMERA_HEIGHT_M, TEACH_DRIVER_ACTIONS

SIDE = 96  # frames of the unit tests, pixels (TEACh's are 900; the camera follows the frames)
MUG = "Mug|+01.00|+00.90|-00.50"
EDH: dict[str, Any] = {
    "game_id": "0a1b2c3d4e5f6a7b_0001",
    "instance_id": "0a1b2c3d4e5f6a7b_0001.edh1",
    "pred_start_idx": 4,
    "dialog_history": [
        # Something is left to do after the history (four steps are driven below); planners that read this
        # short request after Pickup Mug as finished stopped at once here (the planner card's second builds).
        ["Commander", "Hello, put the mug on the dining table please."],
        ["Driver", "ok"],
        ["Driver", " "],
    ],
    "driver_action_history": [
        {
            "action_id": 2,
            "action_name": "Forward",
            "action_idx": 2,
            "time_start": 10.5,
            "obj_interaction_action": 0,
            "oid": None,
            "x": None,
            "y": None,
        },
        {
            "action_id": 200,
            "action_name": "Pickup",
            "action_idx": 15,
            "time_start": 12.0,
            "obj_interaction_action": 1,
            "oid": MUG,
            "x": 0.5,
            "y": 0.6,
        },
    ],
    "driver_image_history": ["driver.frame.10.5.jpeg", "driver.frame.12.0.jpeg"],
}
EDH_NAME = "/data/edh_instances/valid_unseen/0a1b2c3d4e5f6a7b_0001.edh1.json"


def frame(seed: int, side: int = SIDE) -> Image.Image:
    """A floor-and-wall picture with a box on it, shifted by ``seed`` so consecutive frames differ."""
    rows, cols = np.mgrid[0:side, 0:side]
    pixels = np.zeros((side, side, 3), dtype=np.uint8)
    pixels[..., 0] = 120 + (rows * 80 // side)
    pixels[..., 1] = 110
    pixels[..., 2] = 90 + (cols * 60 // side)
    pixels[side // 2 :, :, :] = (150, 130, 100)
    left = (side // 3 + 3 * seed) % (side - side // 4)
    pixels[side // 3 : side // 2, left : left + side // 4] = (200, 40, 40)
    return Image.fromarray(pixels)


def jpeg(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, "jpeg")
    return buffer.getvalue()


def remote(client: TestClient) -> TeachRemoteModel:
    return TeachRemoteModel("", http=client)


Recorder = list[tuple[str, str, bytes]]


def recording(client: TestClient) -> Recorder:
    """Every request the client sends from now on: (path, content type, body)."""
    sent: Recorder = []

    def record(request: Any) -> None:
        sent.append((request.url.path, request.headers.get("content-type", ""), request.read()))

    client.event_hooks = {"request": [record], "response": []}
    return sent


def start(client: TestClient, name: str | None = EDH_NAME, images: int = 2, **changes: Any) -> dict[str, Any]:
    instance = {**EDH, **changes}
    history = [frame(i) for i in range(images)] if images else None
    return remote(client).start_new_edh_instance(instance, history, name)


def session_of(client: TestClient, started: dict[str, Any]) -> dict[str, Any]:
    response = client.get(f"/v1/sessions/{started['session_id']}")
    assert response.status_code == 200, response.text
    return dict(response.json())


def next_form(
    name: str | None = EDH_NAME,
    img: bytes | None = None,
    prev_action: str | None = None,
    img_name: str | None = "img__x_1.jpeg",
) -> dict[str, Any]:
    """A hand-made /get_next_action form: ``data`` and ``files`` for the test client."""
    data = {
        "edh_name": name,
        "img_name": img_name,
        "prev_action": prev_action,
        "edh_instance": json.dumps(EDH),
    }
    files = {"img": (img_name or "img", img if img is not None else jpeg(frame(0)), "image/jpeg")}
    return {"data": {k: v for k, v in data.items() if v is not None}, "files": files}


def test_connection_check_routes(client: TestClient) -> None:
    assert remote(client).test_connection()
    for path in ("/test", "/ping"):
        response = client.get(path)
        assert response.status_code == 200
        assert response.json()["status"] == "ok"


def test_start_replays_the_history_into_a_learned_perception_edh_session(client: TestClient) -> None:
    sent = recording(client)
    started = start(client)
    path, content_type, body = sent[0]
    assert path == "/start_new_edh_instance" and content_type.startswith("multipart/form-data")
    assert body.count(b'name="edh_history_images"; filename="history') == 2
    assert b"Content-Type: image/jpeg" in body
    assert started["success"] is True
    assert started["edh_name"] == EDH_NAME
    assert started["history_frames"] == 2
    assert started["plan"]["source"] == "model"
    session = session_of(client, started)
    assert session["mode"] == "edh"
    assert session["perception"] == "learned"  # TEACh sends RGB only
    assert session["planner"] == "model"
    assert session["camera"] == {"width": SIDE, "height": SIDE, "hfov_deg": 90.0, "height_m": CAMERA_HEIGHT_M}
    assert [s["text"] for s in session["history_subgoals"]] == ["Navigate Mug", "Pickup Mug"]
    said = [t["text"] for t in session["dialogue"]]
    assert said == ["Hello, put the mug on the dining table please.", "ok"]


def test_history_frames_reach_the_map(client: TestClient) -> None:
    """The first step's map already holds what the history frames showed (they were replayed)."""
    explored = []
    for images in (2, 0):
        name = f"{EDH_NAME}.{images}"
        started = start(client, name, images=images)
        remote(client).get_next_action(frame(5), EDH, None, "img__x_1.jpeg", name)
        trace = client.get(f"/v1/sessions/{started['session_id']}/trace").text.splitlines()
        explored.append(json.loads(trace[0])["map"]["explored_m2"])
    with_history, without = explored
    assert with_history > without, f"history frames add nothing to the map: {explored}"


def test_steps_answer_like_teach_expects_and_prev_action_follows(client: TestClient) -> None:
    started = start(client)
    sent = recording(client)
    model = remote(client)
    prev_action = None
    answers = []
    for index in range(4):
        img_name = f"img__{EDH['instance_id']}_{index + 1}.jpeg"
        action, coord = model.get_next_action(frame(index), EDH, prev_action, img_name, EDH_NAME)
        answers.append((action, coord))
        prev_action = {"action": action, "obj_relative_coord": coord}
    assert b'name="prev_action"' not in sent[0][2], "RemoteModel leaves prev_action out on the first step"
    for (_, _, body), (action, coord) in zip(sent[1:], answers, strict=False):
        expected = json.dumps({"action": action, "obj_relative_coord": coord}).encode()
        assert b'name="prev_action"\r\n\r\n' + expected in body
    trace = [
        json.loads(line)
        for line in client.get(f"/v1/sessions/{started['session_id']}/trace").text.splitlines()
    ]
    assert len(trace) == 4
    for entry, (action, coord) in zip(trace, answers, strict=True):
        assert action in TEACH_DRIVER_ACTIONS
        assert action == entry["action"]
        assert coord == (None if entry["x"] is None else [entry["y"], entry["x"]]), "row first: [y, x]"
        assert entry["inputs"]["rgb"] and not entry["inputs"]["depth"] and not entry["inputs"]["segmentation"]
        assert "pose" not in entry["inputs"] and "last_action_success" not in entry["inputs"]


@pytest.mark.parametrize("empty", ["", "null", "{}"])
def test_an_empty_prev_action_on_the_first_step_is_no_prev_action(client: TestClient, empty: str) -> None:
    start(client)
    response = client.post("/get_next_action", **next_form(prev_action=empty))
    assert response.status_code == 200, response.text
    assert set(response.json()) == {"action", "obj_relative_coord"}


def test_without_history_images_the_start_is_urlencoded_and_the_first_frame_sets_the_camera(
    client: TestClient,
) -> None:
    sent = recording(client)
    started = start(client, images=0)
    assert sent[0][1] == "application/x-www-form-urlencoded"  # requests sends no multipart without files
    assert started["history_frames"] == 0
    assert session_of(client, started)["camera"]["width"] == 900  # TEACh's, until a frame says otherwise
    remote(client).get_next_action(frame(0, side=64), EDH, None, "img__x_1.jpeg", EDH_NAME)
    camera = session_of(client, started)["camera"]
    assert (camera["width"], camera["height"], camera["hfov_deg"]) == (64, 64, 90.0)
    step_before = session_of(client, started)["step"]
    response = client.post(
        "/get_next_action", **next_form(img=jpeg(frame(1, side=80)), img_name="img__x_2.jpeg")
    )
    assert response.status_code == 422
    assert response.json()["error"] == "invalid_image"
    assert "img: is 80x80 pixels but the session camera is 64x64" in response.json()["detail"]
    assert session_of(client, started)["step"] == step_before


def test_one_session_per_edh_name(client: TestClient) -> None:
    first = start(client)
    again = start(client)
    other = start(client, name=f"{EDH_NAME}.other")
    assert len({first["session_id"], again["session_id"], other["session_id"]}) == 3
    assert client.get(f"/v1/sessions/{first['session_id']}").status_code == 404  # replaced
    assert client.get(f"/v1/sessions/{again['session_id']}").status_code == 200
    assert client.get(f"/v1/sessions/{other['session_id']}").status_code == 200


def test_without_edh_name_the_instance_id_names_the_instance(client: TestClient) -> None:
    started = start(client, name=None)
    assert started["edh_name"] == EDH["instance_id"]
    action, _ = remote(client).get_next_action(frame(0), EDH, None, "img__x_1.jpeg", None)
    assert action in TEACH_DRIVER_ACTIONS
    assert session_of(client, started)["step"] == 1


def test_a_repeated_img_name_is_a_retry(client: TestClient) -> None:
    started = start(client)
    first = client.post("/get_next_action", **next_form())
    again = client.post("/get_next_action", **next_form())
    assert first.status_code == again.status_code == 200
    assert again.json() == first.json()
    assert session_of(client, started)["step"] == 1


def test_teach_steps_count_in_the_step_metrics_and_a_retry_does_not(client: TestClient) -> None:
    start(client)
    for _ in range(2):  # the second is a retry of the first frame
        assert client.post("/get_next_action", **next_form()).status_code == 200
    samples = {
        sample.name: sample.value
        for family in text_string_to_metric_families(client.get("/metrics").text)
        for sample in family.samples
    }
    assert samples["jarvis_steps_total"] == 1


def test_an_img_part_without_file_name_is_read(client: TestClient) -> None:
    """RemoteModel with ``img_name=None`` sends the image part without a file name (a text part)."""
    started = start(client)
    action, _ = remote(client).get_next_action(frame(0), EDH, None, None, EDH_NAME)
    assert action in TEACH_DRIVER_ACTIONS
    assert session_of(client, started)["step"] == 1


def test_a_prev_action_that_is_not_the_last_answer_is_refused_and_changes_nothing(client: TestClient) -> None:
    started = start(client)
    early = client.post("/get_next_action", **next_form(prev_action=json.dumps({"action": "Forward"})))
    assert early.status_code == 409
    assert early.json()["error"] == "step_out_of_order"
    answer = client.post("/get_next_action", **next_form()).json()
    wrong = "Pickup" if answer["action"] != "Pickup" else "Forward"
    prev = json.dumps({"action": wrong, "obj_relative_coord": None})
    response = client.post("/get_next_action", **next_form(prev_action=prev, img_name="img__x_2.jpeg"))
    assert response.status_code == 409
    assert response.json()["error"] == "step_out_of_order"
    assert f"prev_action {wrong!r} is not the last answer" in response.json()["detail"]
    assert session_of(client, started)["step"] == 1


BAD_STARTS: list[tuple[str, dict[str, Any], dict[str, Any], int, str, str]] = [
    ("no edh_instance", {"edh_name": "a"}, {}, 422, "validation_error", "edh_instance: field required"),
    ("not JSON", {"edh_name": "a", "edh_instance": "{oops"}, {}, 422, "validation_error", "not valid JSON"),
    (
        "not an object",
        {"edh_name": "a", "edh_instance": "[1, 2]"},
        {},
        422,
        "validation_error",
        "JSON object",
    ),
    (
        "no dialogue",
        {"edh_name": "a", "edh_instance": json.dumps({"instance_id": "x"})},
        {},
        422,
        "validation_error",
        "edh_instance.dialog_history: field required",
    ),
    (
        "bad turn",
        {"edh_name": "a", "edh_instance": json.dumps({**EDH, "dialog_history": [["Commander"]]})},
        {},
        422,
        "validation_error",
        "edh_instance.dialog_history[0]",
    ),
    (
        "unknown speaker",
        {"edh_name": "a", "edh_instance": json.dumps({**EDH, "dialog_history": [["Narrator", "hi"]]})},
        {},
        422,
        "validation_error",
        "edh_instance.dialog_history[0].speaker",
    ),
    (
        "unknown object type",
        {
            "edh_name": "a",
            "edh_instance": json.dumps(
                {**EDH, "driver_action_history": [{"action_name": "Pickup", "oid": "Spatula9|1|2|3"}]}
            ),
        },
        {},
        422,
        "unknown_object_type",
        "edh_instance.driver_action_history[0].oid",
    ),
    (
        "one image for two actions",
        {"edh_name": "a", "edh_instance": json.dumps(EDH)},
        {"edh_history_images": ("history0", jpeg(frame(0)), "image/jpeg")},
        422,
        "history_mismatch",
        "edh_history_images has 1 frames but the history has 2 actions",
    ),
]


@pytest.mark.parametrize(
    ("data", "files", "status", "code", "detail"),
    [case[1:] for case in BAD_STARTS],
    ids=[case[0] for case in BAD_STARTS],
)
def test_bad_starts_are_refused_with_the_field_named(
    client: TestClient, data: dict[str, Any], files: dict[str, Any], status: int, code: str, detail: str
) -> None:
    response = client.post("/start_new_edh_instance", data=data, files=files or None)
    assert response.status_code == status, response.text
    assert response.json()["error"] == code
    assert detail in response.json()["detail"]
    assert client.get("/readyz").json()["sessions"] == 0


def test_a_history_image_that_is_no_image_is_refused(client: TestClient) -> None:
    files = [
        ("edh_history_images", ("history0", jpeg(frame(0)), "image/jpeg")),
        ("edh_history_images", ("history1", b"\xff\xd8 not really a jpeg", "image/jpeg")),
    ]
    response = client.post("/start_new_edh_instance", data={"edh_instance": json.dumps(EDH)}, files=files)
    assert response.status_code == 422
    assert response.json()["error"] == "invalid_image"
    assert response.json()["detail"].startswith("edh_history_images[1]")
    assert client.get("/readyz").json()["sessions"] == 0


BAD_STEPS: list[tuple[str, Callable[[], dict[str, Any]], int, str, str]] = [
    ("never started", lambda: next_form(name="nobody"), 404, "edh_instance_not_started", "'nobody'"),
    ("no image", lambda: {"data": next_form()["data"]}, 422, "validation_error", "img: file required"),
    ("not an image", lambda: next_form(img=b"GIF89a nonsense"), 422, "invalid_image", "img:"),
    (
        "text that is no image",
        lambda: {"data": {**next_form()["data"], "img": "h\u00e9llo \u20ac"}},
        422,
        "invalid_image",
        "img: is not a PNG or JPEG image",
    ),
    ("prev_action not JSON", lambda: next_form(prev_action="{"), 422, "validation_error", "prev_action"),
    (
        "unknown prev action",
        lambda: next_form(prev_action=json.dumps({"action": "Jump"})),
        422,
        "validation_error",
        "prev_action.action",
    ),
]


@pytest.mark.parametrize(
    ("form", "status", "code", "detail"),
    [case[1:] for case in BAD_STEPS],
    ids=[case[0] for case in BAD_STEPS],
)
def test_bad_steps_are_refused_and_change_nothing(
    client: TestClient, form: Callable[[], dict[str, Any]], status: int, code: str, detail: str
) -> None:
    started = start(client)
    response = client.post("/get_next_action", **form())
    assert response.status_code == status, response.text
    assert response.json()["error"] == code
    assert detail in response.json()["detail"]
    assert session_of(client, started)["step"] == 0


def test_teach_routes_read_forms_only(client: TestClient) -> None:
    response = client.post("/get_next_action", json={"edh_name": EDH_NAME})
    assert response.status_code == 415
    assert response.json()["error"] == "unsupported_media_type"


def test_the_start_route_has_its_own_body_limit(make_client: Callable[..., TestClient]) -> None:
    """A history is far bigger than any native request: the start route takes up to max_edh_body_bytes."""
    client = make_client(max_body_bytes=8 * 1024, max_edh_body_bytes=2 * 1024 * 1024)
    started = start(client, images=2)  # two noisy JPEG frames: over 8 kB
    assert started["history_frames"] == 2
    big = {
        "mode": "tfd",
        "planner": "oracle",
        "subgoals": "Slice Bread",
        "dialogue": [{"speaker": "Commander", "text": "x" * 90}] * 100,
    }
    assert client.post("/v1/sessions", json=big).status_code == 413
    huge = client.post(
        "/start_new_edh_instance",
        data={"edh_instance": json.dumps(EDH)},
        files=[("edh_history_images", (f"history{i}", b"\xff" * 600_000, "image/jpeg")) for i in range(4)],
    )
    assert huge.status_code == 413
    assert "JARVIS_MAX_EDH_BODY_BYTES" in huge.json()["detail"]


def test_a_full_store_makes_room_by_dropping_finished_teach_sessions(
    make_client: Callable[..., TestClient],
) -> None:
    client = make_client(max_sessions=2, max_steps=1)
    first = start(client, name="first")
    model = remote(client)
    action, coord = model.get_next_action(frame(0), EDH, None, "img__first_1.jpeg", "first")
    prev = {"action": action, "obj_relative_coord": coord}
    assert model.get_next_action(frame(1), EDH, prev, "img__first_2.jpeg", "first")[0] == "Stop"  # step limit
    assert session_of(client, first)["done"] is True
    second = start(client, name="second")
    third = start(client, name="third")  # full: "first" is finished, so it goes
    assert client.get(f"/v1/sessions/{first['session_id']}").status_code == 404
    assert session_of(client, second)["done"] is False and session_of(client, third)["step"] == 0
    response = client.post(
        "/start_new_edh_instance", data={"edh_name": "fourth", "edh_instance": json.dumps(EDH)}
    )
    assert response.status_code == 429  # nothing finished to drop
    assert response.json()["error"] == "too_many_sessions"
