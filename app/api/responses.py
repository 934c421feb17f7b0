"""OpenAPI entries for error answers, so ``/docs`` shows the ``{"error", "detail"}`` body per status."""

from __future__ import annotations

from typing import Any

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
    """``responses=`` for a route: each status with ErrorBody as its schema."""
    return {status: {"model": ErrorBody, "description": _MEANING[status]} for status in statuses}
