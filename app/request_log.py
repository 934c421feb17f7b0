"""Per-request observability in one ASGI middleware: the request id, one log event, the HTTP metrics.

It wraps everything else (it is the last middleware added), so even a 413 that ``app.body_limit`` answers
before any route runs gets an ``X-Request-ID``, a log event and its metrics. The id is the client's when
it is a sane token (at most 128 characters of ``[A-Za-z0-9._-]``: safe to echo and to log), else a fresh
uuid4 hex; it is bound to ``app.logging_json.REQUEST_ID`` so every line logged while serving the request
carries it, and to ``request.state.request_id`` for handlers.

Error codes are read from the error responses themselves: every error body is ``{"error": code, ...}``
(DESIGN.md §4), whichever part wrote it (error handlers, the body limit), so reading the small JSON body
of a 4xx/5xx counts every code without each writer having to report it.
"""

from __future__ import annotations

import functools
import json
import logging
import re
import time
import uuid

from fastapi import FastAPI
from starlette.routing import compile_path
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from agent.model_planner import PLANNER_CALL_OBSERVER
from app.logging_json import REQUEST_ID
from app.metrics import UNMATCHED_ROUTE, ServiceMetrics

_LOG = logging.getLogger("app.request")

REQUEST_ID_HEADER = "X-Request-ID"
PLANNER_TIME_HEADER = "X-Planner-Time-Ms"
"""On an answer for which the language planner ran (a session created or re-planned): its milliseconds,
so a client or a bench can tell the planner's own time from the wait in the worker's queue."""
_PLANNER_TIME_NAME = PLANNER_TIME_HEADER.lower().encode()
_SANE_REQUEST_ID = re.compile(r"[A-Za-z0-9._-]{1,128}")
_MAX_ERROR_BODY = 16 * 1024
"""Bytes of an error body kept to read its code; error bodies are a code and one line of detail."""


def request_id_from(scope: Scope) -> str:
    """The client's ``X-Request-ID`` when it is a sane token, else a new uuid4 hex."""
    for name, value in scope["headers"]:
        if name == b"x-request-id":
            candidate = value.decode("latin-1")
            if _SANE_REQUEST_ID.fullmatch(candidate):
                return candidate
            break
    return uuid.uuid4().hex


def route_template(scope: Scope) -> str:
    """The path template of the route that served (or would serve) the request, e.g.
    ``/v1/sessions/{session_id}/step``; ``unmatched`` when no route matches the path."""
    path = getattr(scope.get("route"), "path", None)
    if isinstance(path, str):
        return path
    # Answered before routing (a 413 from the body limit): match the path against the documented
    # templates (the OpenAPI paths, FastAPI's public and cached view of every route with its prefixes).
    app = scope.get("app")
    if isinstance(app, FastAPI):
        for template in app.openapi().get("paths", {}):
            if _compiled(template).fullmatch(scope["path"]):
                return str(template)
    return UNMATCHED_ROUTE


@functools.lru_cache(maxsize=256)
def _compiled(template: str) -> re.Pattern[str]:
    regex, _, _ = compile_path(template)
    return regex


def error_code(status: int, content_type: str, body: bytes) -> str:
    """The ``error`` field of an error body; ``http_<status>`` when the body has none."""
    if content_type.startswith("application/json"):
        try:
            code = json.loads(body).get("error")
        except (ValueError, AttributeError):
            code = None
        if isinstance(code, str) and code:
            return code
    return f"http_{status}"


class RequestLog:
    """ASGI middleware: ``X-Request-ID`` on every response, ``http_request`` logged with the fields an
    operator filters on, and the request and error metrics of ``metrics``."""

    def __init__(self, app: ASGIApp, metrics: ServiceMetrics) -> None:
        self.app = app
        self.metrics = metrics

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        request_id = request_id_from(scope)
        scope.setdefault("state", {})["request_id"] = request_id
        status = 500
        content_type = ""
        error_body = bytearray()

        async def recording_send(message: Message) -> None:
            nonlocal status, content_type
            if message["type"] == "http.response.start":
                status = message["status"]
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() != b"x-request-id"]
                headers.append((b"x-request-id", request_id.encode()))
                if planner_s:
                    headers.append((_PLANNER_TIME_NAME, f"{sum(planner_s) * 1e3:.3f}".encode()))
                message = {**message, "headers": headers}
                for name, value in headers:
                    if name.lower() == b"content-type":
                        content_type = value.decode("latin-1")
            elif message["type"] == "http.response.body" and status >= 400:
                room = _MAX_ERROR_BODY - len(error_body)
                if room > 0:
                    error_body.extend(message.get("body", b"")[:room])
            await send(message)

        planner_s: list[float] = []

        def observe_planner(seconds: float) -> None:
            planner_s.append(seconds)
            self.metrics.observe_planner_call(seconds)

        id_token = REQUEST_ID.set(request_id)
        observer_token = PLANNER_CALL_OBSERVER.set(observe_planner)
        try:
            await self.app(scope, receive, recording_send)
        finally:
            seconds = time.perf_counter() - started
            route = route_template(scope)
            fields: dict[str, object] = {
                "request_id": request_id,
                "method": scope["method"],
                "path": scope["path"],
                "route": route,
                "status": status,
                "duration_ms": round(seconds * 1000.0, 3),
            }
            if planner_s:
                fields["planner_ms"] = round(sum(planner_s) * 1000.0, 3)
            if status >= 400:
                code = error_code(status, content_type, bytes(error_body))
                fields["error"] = code
                self.metrics.observe_error(code)
            self.metrics.observe_request(route, scope["method"], status, seconds)
            _LOG.info("http_request", extra=fields)
            PLANNER_CALL_OBSERVER.reset(observer_token)
            REQUEST_ID.reset(id_token)
