"""Who may call: the API key check and the per-key request rate, before anything reads the body.

A pure ASGI middleware, so an unauthenticated client is refused (401) before the service reads, buffers or
parses a byte of its body (TEACh's start route takes up to 256 MiB), and a key over its rate (429 with
Retry-After) costs one Redis round trip at most. The caller it finds is left in the request's state for
the routes (``app.api.deps.CallerDep``). Without configured keys the service is open and this passes
every request through as the owner None. Health, readiness, TEACh's liveness routes and the API's
documentation need no key (an orchestrator and a person reading /docs have none to send).
"""

from __future__ import annotations

import json
import logging
import re

import redis
from starlette.types import ASGIApp, Receive, Scope, Send

from app.api_docs import DOCS_OPEN_PATHS
from app.errors import NOT_READY, RATE_LIMITED, STORE_UNAVAILABLE, UNAUTHORIZED
from app.keys import KeyRing, presented_key
from app.ownership import Caller
from app.rate_limit import RateLimiter, retry_after_header
from app.settings import Settings

OPEN_PATHS: frozenset[str] = (
    frozenset({"/healthz", "/readyz", "/ping", "/test", "/openapi.json"}) | DOCS_OPEN_PATHS
)
"""Routes that answer without a key: probes, TEACh's connection checks, and the API's description."""
OPEN_PAGES = re.compile(r"/v1/view(/live\.(js|css))?|/v1/sessions/[^/]+/view")
"""The live pages and their script and style: static files with no session data in them; the script sends
the key with its requests (``app.api.routes.live``)."""
CALLER_STATE = "caller"
"""Key of the ``Caller`` in the ASGI scope's state."""

_LOG = logging.getLogger("app.access")


class KeyCheck:
    """ASGI middleware: 401 ``unauthorized`` without a valid key, 429 ``rate_limited`` over the key's rate."""

    def __init__(self, app: ASGIApp, settings: Settings) -> None:
        self.app = app
        self.settings = settings

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        path = scope.get("path", "")
        if scope["type"] != "http" or path in OPEN_PATHS or OPEN_PAGES.fullmatch(path):
            await self.app(scope, receive, send)
            return
        state = scope["app"].state
        keys: KeyRing | None = getattr(state, "keys", None)
        limiter: RateLimiter | None = getattr(state, "rate_limiter", None)
        if keys is None or limiter is None:
            await _refuse(
                send, 503, NOT_READY, "the key ring is not loaded yet (the service is starting)", {}
            )
            return
        caller = Caller(owner=None, key=None)
        if not keys.open:
            headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
            secret = presented_key(headers)
            key = keys.identify(secret) if secret is not None else None
            if key is None:
                what = "no API key was sent" if secret is None else "the API key is not valid"
                _LOG.info("request_unauthorized", extra={"path": scope.get("path"), "reason": what})
                await _refuse(
                    send,
                    401,
                    UNAUTHORIZED,
                    f"{what}; send it as 'Authorization: Bearer KEY' or 'X-API-Key: KEY' (TEACh's "
                    "RemoteModel: --model_api_host_and_port KEY@host:port)",
                    {"WWW-Authenticate": 'Bearer realm="jarvis"'},
                )
                return
            rate = key.rate_per_s or self.settings.rate_per_key_per_s
            burst = key.burst or self.settings.rate_burst_per_key
            try:
                wait_s = limiter.take(key.name, rate, burst)
            except redis.RedisError as error:
                _LOG.warning("store_unavailable", extra={"error": f"{type(error).__name__}: {error}"})
                await _refuse(
                    send,
                    503,
                    STORE_UNAVAILABLE,
                    f"the rate limiter's store did not answer ({type(error).__name__}); send the request "
                    "again shortly",
                    {"Retry-After": "1"},
                )
                return
            if wait_s > 0:
                await _refuse(
                    send,
                    429,
                    RATE_LIMITED,
                    f"API key {key.name!r} sent more than {rate:g} requests/s (burst {burst}); retry after "
                    f"{wait_s:.2f} s (settings JARVIS_RATE_PER_KEY_PER_S, JARVIS_RATE_BURST_PER_KEY, or the "
                    "key's own rate_per_s and burst)",
                    {"Retry-After": retry_after_header(wait_s)},
                )
                return
            caller = Caller(owner=key.name, key=key)
        scope.setdefault("state", {})[CALLER_STATE] = caller
        await self.app(scope, receive, send)


async def _refuse(send: Send, status: int, code: str, detail: str, headers: dict[str, str]) -> None:
    body = json.dumps({"error": code, "detail": detail}).encode()
    raw_headers = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        *((name.lower().encode("latin-1"), value.encode("latin-1")) for name, value in headers.items()),
    ]
    await send({"type": "http.response.start", "status": status, "headers": raw_headers})
    await send({"type": "http.response.body", "body": body})
