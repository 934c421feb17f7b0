"""One exception for every client-visible failure, and the error codes clients may rely on.

DESIGN.md §4: every bad input gets a 4xx with ``{"error": code, "detail": human text}``. Codes are
stable strings (a client branches on them); details are for people and may change wording.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

# Request shape and transport.
VALIDATION_ERROR = "validation_error"
MALFORMED_JSON = "malformed_json"
PAYLOAD_TOO_LARGE = "payload_too_large"
NOT_FOUND = "not_found"
METHOD_NOT_ALLOWED = "method_not_allowed"
INTERNAL_ERROR = "internal_error"
NOT_READY = "not_ready"
REQUEST_TIMEOUT = "request_timeout"
OVERLOADED = "overloaded"

# Sessions.
SESSION_NOT_FOUND = "session_not_found"
TOO_MANY_SESSIONS = "too_many_sessions"
STEP_IN_PROGRESS = "step_in_progress"
STEP_OUT_OF_ORDER = "step_out_of_order"
LEASE_LOST = "lease_lost"
SESSION_UNREADABLE = "session_unreadable"
STORE_UNAVAILABLE = "store_unavailable"

# Keys and quotas.
UNAUTHORIZED = "unauthorized"
RATE_LIMITED = "rate_limited"

# Session content.
PLANNER_UNAVAILABLE = "planner_unavailable"
PERCEPTION_UNAVAILABLE = "perception_unavailable"
SUBGOALS_REQUIRED = "subgoals_required"
INVALID_SUBGOALS = "invalid_subgoals"
UNKNOWN_OBJECT_TYPE = "unknown_object_type"
TOO_MANY_SUBGOALS = "too_many_subgoals"
CAMERA_TOO_LARGE = "camera_too_large"
UTTERANCE_TOO_LONG = "utterance_too_long"
TOO_MANY_UTTERANCES = "too_many_utterances"
HISTORY_MISMATCH = "history_mismatch"
HISTORY_TOO_LONG = "history_too_long"

# TEACh's RemoteModel protocol.
EDH_INSTANCE_NOT_STARTED = "edh_instance_not_started"
MALFORMED_FORM = "malformed_form"
UNSUPPORTED_MEDIA_TYPE = "unsupported_media_type"

# Observations (the step route).
MISSING_OBSERVATION = "missing_observation"
INVALID_IMAGE = "invalid_image"
INVALID_DEPTH = "invalid_depth"
INVALID_SEGMENTATION = "invalid_segmentation"
INVALID_POSE = "invalid_pose"


def unknown_object_type(field: str, name: str, suggestions: Sequence[str]) -> ApiError:
    """422 for a name that is no AI2-THOR object type, with the closest types so the caller can fix it."""
    if suggestions:
        hint = f"closest types: {', '.join(suggestions)}"
    else:
        hint = "no type is close; names are AI2-THOR object types such as Apple, Bread, Fridge, Knife, Mug"
    return ApiError(422, UNKNOWN_OBJECT_TYPE, f"{field}: unknown object type {name!r}; {hint}")


class ApiError(Exception):
    """A failure the client caused (or must know about), rendered as ``{"error", "detail"}``."""

    def __init__(self, status: int, code: str, detail: str, headers: Mapping[str, str] | None = None) -> None:
        super().__init__(f"{status} {code}: {detail}")
        self.status = status
        self.code = code
        self.detail = detail
        self.headers = dict(headers or {})  # e.g. Retry-After on a 429, WWW-Authenticate on a 401
