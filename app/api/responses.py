"""OpenAPI entries for error answers, so ``/docs`` and ``/redoc`` show the ``{"error", "detail"}`` body per
status, with an example of each error code that the route can really answer with that status.

Routes name their error statuses with ``error_responses`` (the statuses are what schemathesis holds the
answers to). Which codes stand behind each status differs by route: a 404 of a session route is
``session_not_found``, of TEACh's ``/get_next_action`` ``edh_instance_not_started``. ``ROUTE_ERRORS``
lists them per operation, read from where each code is raised (``app.errors`` names the codes), and
``add_error_examples`` writes them into the generated document.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.errors import (
    CAMERA_TOO_LARGE,
    EDH_INSTANCE_NOT_STARTED,
    HISTORY_MISMATCH,
    HISTORY_TOO_LONG,
    INVALID_DEPTH,
    INVALID_IMAGE,
    INVALID_POSE,
    INVALID_SEGMENTATION,
    INVALID_SUBGOALS,
    LEASE_LOST,
    MALFORMED_FORM,
    MALFORMED_JSON,
    MISSING_OBSERVATION,
    NOT_READY,
    OVERLOADED,
    PAYLOAD_TOO_LARGE,
    PERCEPTION_UNAVAILABLE,
    PLANNER_UNAVAILABLE,
    RATE_LIMITED,
    SESSION_NOT_FOUND,
    SESSION_UNREADABLE,
    STEP_IN_PROGRESS,
    STEP_OUT_OF_ORDER,
    STORE_UNAVAILABLE,
    SUBGOALS_REQUIRED,
    TOO_MANY_SESSIONS,
    TOO_MANY_SUBGOALS,
    TOO_MANY_UTTERANCES,
    UNAUTHORIZED,
    UNKNOWN_OBJECT_TYPE,
    UNSUPPORTED_MEDIA_TYPE,
    UTTERANCE_TOO_LONG,
    VALIDATION_ERROR,
)
from app.schemas import ErrorBody

_MEANING = {
    400: "Malformed JSON or form (error malformed_json, malformed_form).",
    401: "No valid API key (error unauthorized): send Authorization: Bearer KEY or X-API-Key.",
    404: "Unknown or expired session, or another API key's (error session_not_found, "
    "edh_instance_not_started).",
    408: "The request body stopped arriving (error request_timeout; the connection is closed).",
    409: "The session is busy with another request (Retry-After), or the step index is out of order.",
    410: "The session was stored by another version of the service and cannot be read (session_unreadable).",
    413: "Body, dialogue, EDH history or plan over the configured limit.",
    415: "A TEACh route was sent something other than a form (error unsupported_media_type).",
    422: "Invalid input; the detail names the field (validation_error, unknown_object_type, ...).",
    429: "The store or the key's share is full (too_many_sessions), or the key's request rate is exceeded "
    "(rate_limited); Retry-After says when to try again.",
    501: "Valid request for a part that is not built yet (error not_implemented).",
    503: "The service is starting (not_ready), overloaded (overloaded), or its session store does not "
    "answer (store_unavailable); see Retry-After.",
}


def error_responses(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` for a route: each status with ErrorBody as its schema (examples: ``ROUTE_ERRORS``)."""
    return {status: {"model": ErrorBody, "description": _MEANING[status]} for status in statuses}


@dataclass(frozen=True)
class ErrorExample:
    """One error code as the documentation shows it: its status, what it means, a detail as sent."""

    status: int
    summary: str
    detail: str


_SESSION = "3f2c9a0e5b7d4c1e"
ERROR_EXAMPLES: Mapping[str, ErrorExample] = {
    MALFORMED_JSON: ErrorExample(
        400, "The body is not JSON", "the request body is not valid JSON: Expecting ',' delimiter at byte 15"
    ),
    MALFORMED_FORM: ErrorExample(
        400, "The multipart form cannot be read", "the multipart body's content type names no boundary"
    ),
    UNAUTHORIZED: ErrorExample(
        401,
        "No valid API key (only when the service has keys)",
        "no API key was sent; send it as 'Authorization: Bearer KEY' or 'X-API-Key: KEY' (TEACh's "
        "RemoteModel: --model_api_host_and_port KEY@host:port)",
    ),
    SESSION_NOT_FOUND: ErrorExample(
        404,
        "Unknown or expired session, or another key's",
        f"no session '{_SESSION}' (never created, deleted, evicted after being idle past the TTL, or made "
        "with another API key)",
    ),
    EDH_INSTANCE_NOT_STARTED: ErrorExample(
        404,
        "No such EDH instance started",
        "no EDH instance 'edh_instances/valid_unseen/7d2a79f43e605c36_1657.edh0.json' was started (or its "
        "session expired); POST /start_new_edh_instance first, as TEACh's runner does before each instance",
    ),
    STEP_IN_PROGRESS: ErrorExample(
        409,
        "The session is busy with another request (Retry-After)",
        f"session '{_SESSION}' is busy with another request for over 1.0 s; retry when it has answered",
    ),
    STEP_OUT_OF_ORDER: ErrorExample(
        409,
        "Not the step the session expects",
        f"step 7 was sent but session '{_SESSION}' expects step 5 (or 4 again, to repeat the last answer)",
    ),
    LEASE_LOST: ErrorExample(
        409,
        "Another worker took the session over; nothing was stored (Retry-After)",
        f"session {_SESSION}: the request took longer than its 6.0 s lease and another request took the "
        "session over; this request's changes were not kept; send the request again",
    ),
    SESSION_UNREADABLE: ErrorExample(
        410,
        "Stored by another version of the service",
        f"session '{_SESSION}' was stored in a form this version of the service does not read (snapshot "
        "names an unknown process-wide object 'planner:gpt'); start a new session",
    ),
    PAYLOAD_TOO_LARGE: ErrorExample(
        413,
        "Body over the limit",
        "the request body declares 40000000 bytes; the limit is 33554432 bytes (setting "
        "JARVIS_MAX_BODY_BYTES)",
    ),
    TOO_MANY_UTTERANCES: ErrorExample(
        413,
        "Dialogue over the limit",
        "the dialogue would hold 501 turns; at most 500 are kept per session (setting "
        "JARVIS_MAX_DIALOGUE_TURNS)",
    ),
    TOO_MANY_SUBGOALS: ErrorExample(
        413,
        "Plan over the limit",
        "subgoals: the plan has 320 subgoals; at most 300 are accepted (setting JARVIS_MAX_SUBGOALS)",
    ),
    HISTORY_TOO_LONG: ErrorExample(
        413,
        "EDH history over the limit",
        "history.actions has 1200 actions; at most 1000 are accepted (a TEACh game ends at 1000 steps; "
        "setting JARVIS_MAX_HISTORY_ACTIONS)",
    ),
    UNSUPPORTED_MEDIA_TYPE: ErrorExample(
        415,
        "Not a form",
        "this TEACh route reads a form (multipart/form-data or application/x-www-form-urlencoded), as "
        "TEACh's RemoteModel sends; got application/json",
    ),
    VALIDATION_ERROR: ErrorExample(
        422,
        "A field is missing or out of range",
        "camera.hfov_deg: Input should be less than or equal to 150 (got 200)",
    ),
    CAMERA_TOO_LARGE: ErrorExample(
        422,
        "Camera over the largest side",
        "camera.width is 4096 px; the largest accepted side is 2048 px (setting JARVIS_MAX_IMAGE_SIDE)",
    ),
    UTTERANCE_TOO_LONG: ErrorExample(
        422,
        "Utterance over the limit",
        "text has 2400 characters; at most 2000 are accepted (setting JARVIS_MAX_UTTERANCE_CHARS)",
    ),
    UNKNOWN_OBJECT_TYPE: ErrorExample(
        422,
        "Not an AI2-THOR object type",
        "subgoals: unknown object type 'Bred'; closest types: Bread, Bed, DogBed, StoveBurner",
    ),
    INVALID_SUBGOALS: ErrorExample(
        422,
        "Subgoals that do not parse",
        "subgoals: subgoal 1 ('Chop Bread'): expected an action (Navigate, Pickup, Place, Open, Close, "
        "ToggleOn, ToggleOff, Slice, Pour), got 'Chop Bread'",
    ),
    SUBGOALS_REQUIRED: ErrorExample(
        422,
        "The oracle planner without subgoals",
        "subgoals: the oracle planner needs subgoals (text or a list); none were given",
    ),
    PLANNER_UNAVAILABLE: ErrorExample(
        422,
        "The language planner cannot be loaded",
        "no planner checkpoint at /srv/models/planner. Available planners: model, oracle; planner 'oracle' "
        "with 'subgoals' needs no model.",
    ),
    PERCEPTION_UNAVAILABLE: ErrorExample(
        422,
        "Learned perception cannot be loaded",
        "perception 'learned' needs trained networks that this installation lacks (no checkpoint at "
        "/srv/models/depth); use perception 'oracle' (depth and segmentation with every step)",
    ),
    HISTORY_MISMATCH: ErrorExample(
        422,
        "History frames and actions differ in number",
        "history.images has 3 frames but history.actions has 4 entries; send one frame per action (the view "
        "before it)",
    ),
    MISSING_OBSERVATION: ErrorExample(
        422,
        "An image the session's perception needs is missing",
        "perception 'oracle' needs depth, segmentation, segmentation_legend with every step; missing: depth",
    ),
    INVALID_IMAGE: ErrorExample(
        422,
        "Not a PNG or JPEG, or not the camera's size",
        "rgb: is 32x24 pixels but the session camera is 16x16",
    ),
    INVALID_DEPTH: ErrorExample(
        422,
        "Depth that is not finite and non-negative",
        "depth: has 255 NaN pixel(s); depth must be finite metres",
    ),
    INVALID_SEGMENTATION: ErrorExample(
        422,
        "Instance ids that do not fit",
        "segmentation_legend: instance id 4294967296 is outside 0..4294967295 (ids of an 8-32 bit image)",
    ),
    INVALID_POSE: ErrorExample(
        422,
        "A pose the session's map cannot hold",
        "pose: (60.000, 0.000) lies outside what this session's map can hold: x in [-18.00, 20.00), z in "
        "[-18.00, 20.00) metres (a map spans at most 20 m a side and keeps what it has seen)",
    ),
    TOO_MANY_SESSIONS: ErrorExample(
        429,
        "The store or the key's share is full (Retry-After)",
        "this API key holds its maximum of 64 sessions; delete finished sessions or wait for idle ones to "
        "expire (setting JARVIS_MAX_SESSIONS_PER_KEY, or the key's own max_sessions; idle TTL "
        "JARVIS_SESSION_TTL_S=1800.0)",
    ),
    RATE_LIMITED: ErrorExample(
        429,
        "The key's request rate is exceeded (Retry-After)",
        "API key 'alice' sent more than 200 requests/s (burst 400); retry after 0.05 s (settings "
        "JARVIS_RATE_PER_KEY_PER_S, JARVIS_RATE_BURST_PER_KEY, or the key's own rate_per_s and burst)",
    ),
    NOT_READY: ErrorExample(503, "Models still loading", "not loaded yet: language planner"),
    OVERLOADED: ErrorExample(
        503,
        "Queued too long; nothing was done (Retry-After)",
        "the service is overloaded: this request waited 21.3 s for a worker, more than 20 s (setting "
        "JARVIS_REQUEST_QUEUE_DEADLINE_S); nothing was done, retry later",
    ),
    STORE_UNAVAILABLE: ErrorExample(
        503,
        "Redis did not answer (Retry-After)",
        "the session store did not answer (ConnectionError); send the request again shortly",
    ),
}
"""Every code a route documents, with the status it is always sent with."""

_KEYED = (UNAUTHORIZED, RATE_LIMITED)
"""Any route but health and readiness, when the service has API keys (app.access)."""
_SERVED = (OVERLOADED, STORE_UNAVAILABLE)
"""A route behind the queue deadline (app.deadline) that reads the store (Redis may not answer)."""
_READ = (SESSION_NOT_FOUND,)
"""A read of the caller's session, served from its last published view (app.live_view): never busy."""
_WRITE = (SESSION_NOT_FOUND, STEP_IN_PROGRESS, SESSION_UNREADABLE, LEASE_LOST)
"""A route that holds the session (app.store_errors) and stores what it changed (Redis: under a lease)."""

ROUTE_ERRORS: Mapping[tuple[str, str], tuple[str, ...]] = {
    ("post", "/v1/sessions"): (
        *_KEYED,
        *_SERVED,
        MALFORMED_JSON,
        PAYLOAD_TOO_LARGE,
        TOO_MANY_UTTERANCES,
        TOO_MANY_SUBGOALS,
        HISTORY_TOO_LONG,
        VALIDATION_ERROR,
        CAMERA_TOO_LARGE,
        UTTERANCE_TOO_LONG,
        UNKNOWN_OBJECT_TYPE,
        INVALID_SUBGOALS,
        SUBGOALS_REQUIRED,
        PLANNER_UNAVAILABLE,
        PERCEPTION_UNAVAILABLE,
        HISTORY_MISMATCH,
        INVALID_IMAGE,
        TOO_MANY_SESSIONS,
    ),
    ("get", "/v1/sessions"): (*_KEYED, *_SERVED),
    ("get", "/v1/sessions/{session_id}"): (*_KEYED, *_SERVED, *_READ),
    ("delete", "/v1/sessions/{session_id}"): (*_KEYED, *_SERVED, *_READ),
    ("post", "/v1/sessions/{session_id}/utterances"): (
        *_KEYED,
        *_SERVED,
        *_WRITE,
        MALFORMED_JSON,
        PAYLOAD_TOO_LARGE,
        TOO_MANY_UTTERANCES,
        TOO_MANY_SUBGOALS,
        VALIDATION_ERROR,
        UTTERANCE_TOO_LONG,
        INVALID_SUBGOALS,
    ),
    ("post", "/v1/sessions/{session_id}/step"): (
        *_KEYED,
        *_SERVED,
        *_WRITE,
        STEP_OUT_OF_ORDER,
        MALFORMED_JSON,
        MALFORMED_FORM,
        PAYLOAD_TOO_LARGE,
        VALIDATION_ERROR,
        MISSING_OBSERVATION,
        INVALID_IMAGE,
        INVALID_DEPTH,
        INVALID_SEGMENTATION,
        INVALID_POSE,
        UNKNOWN_OBJECT_TYPE,
    ),
    ("get", "/v1/sessions/{session_id}/trace"): (*_KEYED, *_SERVED, *_READ, VALIDATION_ERROR),
    ("get", "/v1/sessions/{session_id}/map.png"): (*_KEYED, *_SERVED, *_READ),
    ("get", "/readyz"): (NOT_READY, STORE_UNAVAILABLE),
    ("get", "/metrics"): _KEYED,
    ("post", "/start_new_edh_instance"): (
        *_KEYED,
        *_SERVED,
        MALFORMED_FORM,
        PAYLOAD_TOO_LARGE,
        HISTORY_TOO_LONG,
        UNSUPPORTED_MEDIA_TYPE,
        VALIDATION_ERROR,
        INVALID_IMAGE,
        PLANNER_UNAVAILABLE,
        PERCEPTION_UNAVAILABLE,
        TOO_MANY_SESSIONS,
    ),
    ("post", "/get_next_action"): (
        *_KEYED,
        *_SERVED,
        STEP_IN_PROGRESS,
        LEASE_LOST,
        SESSION_UNREADABLE,
        STEP_OUT_OF_ORDER,
        EDH_INSTANCE_NOT_STARTED,
        MALFORMED_FORM,
        PAYLOAD_TOO_LARGE,
        UNSUPPORTED_MEDIA_TYPE,
        VALIDATION_ERROR,
        INVALID_IMAGE,
    ),
}
"""(method, path) -> the error codes the operation can answer, by where app/ raises them."""


def add_error_examples(openapi: dict[str, Any]) -> None:
    """Give each documented error status of each operation in ``ROUTE_ERRORS`` one example per code the
    route answers with that status, and a description naming those codes. An operation or status without
    codes keeps the generic description and ErrorBody's own example."""
    for path, item in openapi.get("paths", {}).items():
        for method, operation in item.items():
            codes = ROUTE_ERRORS.get((method, path), ())
            for status, response in operation.get("responses", {}).items():
                shown = [code for code in codes if str(ERROR_EXAMPLES[code].status) == status]
                if not shown or "application/json" not in response.get("content", {}):
                    continue
                response["description"] = "; ".join(
                    f"`{code}`: {ERROR_EXAMPLES[code].summary}" for code in shown
                )
                response["content"]["application/json"]["examples"] = {
                    code: {
                        "summary": ERROR_EXAMPLES[code].summary,
                        "value": {"error": code, "detail": ERROR_EXAMPLES[code].detail},
                    }
                    for code in shown
                }
