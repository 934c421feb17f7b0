"""Every failure becomes ``{"error": code, "detail": text}`` with the right status (DESIGN.md §4)."""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import redis
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.routing import Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.body_limit import BodyRefused
from app.errors import (
    INTERNAL_ERROR,
    MALFORMED_JSON,
    METHOD_NOT_ALLOWED,
    NOT_FOUND,
    STORE_UNAVAILABLE,
    VALIDATION_ERROR,
    ApiError,
)

_LOG = logging.getLogger("app.errors")
_MAX_SHOWN_INPUT = 80  # characters of an offending value quoted back in a detail
_HTTP_CODES = {400: MALFORMED_JSON, 404: NOT_FOUND, 405: METHOD_NOT_ALLOWED}
_HTTP_METHODS = ("DELETE", "GET", "HEAD", "OPTIONS", "PATCH", "POST", "PUT")


def error_response(
    status: int, code: str, detail: str, headers: Mapping[str, str] | None = None
) -> JSONResponse:
    return JSONResponse(status_code=status, content={"error": code, "detail": detail}, headers=headers)


def _location(loc: Sequence[Any]) -> str:
    """``("body", "camera", "width")`` -> ``camera.width``; list indices as ``[0]``."""
    parts: list[str] = []
    for item in loc[1:] if loc and loc[0] == "body" else loc:
        if isinstance(item, int):
            parts.append(f"[{item}]")
        else:
            parts.append(f".{item}" if parts else str(item))
    return "".join(parts) or "body"


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= _MAX_SHOWN_INPUT else text[: _MAX_SHOWN_INPUT - 3] + "..."


def validation_detail(errors: Sequence[Any]) -> str:
    """One line per problem: field path, pydantic's message, and the value that was sent."""
    lines = []
    for error in errors:
        line = f"{_location(error.get('loc', ()))}: {error.get('msg', 'invalid')}"
        if error.get("type") not in {"missing", "extra_forbidden"} and "input" in error:
            line += f" (got {_shown(error['input'])})"
        elif error.get("type") == "extra_forbidden":
            line += " (unknown field)"
        lines.append(line)
    return "; ".join(lines)


async def _api_error(_: Request, error: Exception) -> JSONResponse:
    assert isinstance(error, ApiError)
    return error_response(error.status, error.code, error.detail, headers=error.headers or None)


async def _validation_error(_: Request, error: Exception) -> JSONResponse:
    assert isinstance(error, RequestValidationError)
    errors = list(error.errors())
    malformed = [e for e in errors if e.get("type") == "json_invalid"]
    if malformed:
        reason = malformed[0].get("ctx", {}).get("error", "not JSON")
        position = malformed[0].get("loc", ("body", "?"))[-1]
        return error_response(
            400, MALFORMED_JSON, f"the request body is not valid JSON: {reason} at byte {position}"
        )
    return error_response(422, VALIDATION_ERROR, validation_detail(errors))


async def _http_error(request: Request, error: Exception) -> JSONResponse:
    assert isinstance(error, StarletteHTTPException)
    status, headers = error.status_code, error.headers
    if status == 404:
        detail = f"no route {request.method} {request.url.path}; the API is described at /docs"
    elif status == 405:
        allowed = _allowed_methods(request) or (headers or {}).get("Allow", "")
        headers = {**(headers or {}), "Allow": allowed}
        detail = f"{request.method} is not allowed on {request.url.path}; allowed: {allowed}"
    else:
        detail = str(error.detail)
    return error_response(status, _HTTP_CODES.get(status, f"http_{status}"), detail, headers=headers)


def _allowed_methods(request: Request) -> str:
    """Every method some route serves at the request's path. Starlette's 405 names only the first route
    that matched the path (``POST /v1/sessions`` said ``Allow: POST``, though ``GET`` is served too)."""
    routes = request.app.router.routes
    return ", ".join(
        method
        for method in _HTTP_METHODS
        if any(route.matches({**request.scope, "method": method})[0] is Match.FULL for route in routes)
    )


def _internal_error(error: Exception) -> JSONResponse:
    return error_response(
        500,
        INTERNAL_ERROR,
        f"unexpected {type(error).__name__} while serving the request; see the server log",
    )


async def _unexpected_error(request: Request, error: Exception) -> JSONResponse:
    _LOG.exception("unhandled_error", extra={"method": request.method, "path": request.url.path})
    return _internal_error(error)


class UnhandledErrors:
    """ASGI middleware answering an unexpected exception with the 500 body, without re-raising it.

    Starlette's ServerErrorMiddleware sends the 500 and then re-raises so the server sees the error; uvicorn
    then drops the keep-alive connection without ``Connection: close``, so a pooled client's next, valid
    request on that connection failed too. Here the error is logged (``unhandled_error`` with its
    traceback) and answered, and the request ends normally. An error after the response started cannot be
    answered any more: it is re-raised, and the server closes the connection, as it must.
    """

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def tracking_send(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except BodyRefused:
            raise  # the body limits' own signal: BodySizeLimit answers it
        except Exception as error:
            _LOG.exception("unhandled_error", extra={"method": scope["method"], "path": scope["path"]})
            if started:
                raise
            await _internal_error(error)(scope, receive, send)


async def _store_unavailable(_: Request, error: Exception) -> JSONResponse:
    """Redis did not answer (down, restarting, unreachable): the request can be sent again. A step that was
    stored before the connection failed is answered from the store when its index is sent again."""
    _LOG.warning("store_unavailable", extra={"error": f"{type(error).__name__}: {error}"})
    return error_response(
        503,
        STORE_UNAVAILABLE,
        f"the session store did not answer ({type(error).__name__}); send the request again shortly",
        headers={"Retry-After": "1"},
    )


def install_error_handlers(app: FastAPI) -> None:
    """Register the handlers that shape every error body."""
    app.add_exception_handler(ApiError, _api_error)
    app.add_exception_handler(redis.RedisError, _store_unavailable)
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.add_exception_handler(StarletteHTTPException, _http_error)
    app.add_exception_handler(Exception, _unexpected_error)  # errors raised outside UnhandledErrors
    # Added before the other middleware, so it sits innermost: the request log sees its 500.
    app.add_middleware(UnhandledErrors)
