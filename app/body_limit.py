"""Refuse request bodies over the limit, or that stop arriving, before anything parses them (DESIGN.md §4).

A pure ASGI middleware so it sees the raw byte stream: a declared ``Content-Length`` over the limit is
refused without reading a byte, and a body without one (chunked) is counted as it streams and cut off
the moment it passes the limit, so a client cannot make the process buffer an unbounded body. A route
may have its own limit (``path_limits``): TEACh's ``/start_new_edh_instance`` carries a whole EDH history
of JPEG frames, far more than any native request.

Slow clients: a body that goes ``read_timeout_s`` without a new chunk answers 408 ``request_timeout`` with
``Connection: close``, so a client that sends headers and part of a body cannot hold a connection (and
what was buffered of its body) forever. The moment the body was read in full is noted in the request's
state (``QUEUED_SINCE``): from there the request waits for a worker thread, which ``app.deadline`` bounds.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable, Mapping

import anyio
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.errors import PAYLOAD_TOO_LARGE, REQUEST_TIMEOUT

QUEUED_SINCE = "queued_since"
"""Request state key: monotonic seconds when the request was ready for its handler (its body read in full,
or its arrival while the body is unread)."""


class BodyRefused(Exception):
    """Raised from ``receive`` to stop the application reading a body this middleware refuses."""


class _BodyTooLarge(BodyRefused):
    """The body passed its limit."""


class _BodyTimedOut(BodyRefused):
    """No body chunk arrived within the read timeout."""


class BodySizeLimit:
    """ASGI middleware answering 413 ``payload_too_large`` to bodies over ``max_body_bytes`` (or over the
    limit ``path_limits`` gives the request's exact path, with the setting that sets it), and 408
    ``request_timeout`` when no body chunk arrives for ``read_timeout_s`` (None: wait forever)."""

    def __init__(
        self,
        app: ASGIApp,
        max_body_bytes: int,
        path_limits: Mapping[str, tuple[int, str]] | None = None,
        read_timeout_s: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        limits = {"": (max_body_bytes, "JARVIS_MAX_BODY_BYTES"), **(path_limits or {})}
        for path, (limit, _) in limits.items():
            if limit < 1:
                raise ValueError(f"the body limit of {path or 'every path'!r} must be positive, got {limit}")
        if read_timeout_s is not None and not read_timeout_s > 0:
            raise ValueError(f"read_timeout_s must be positive seconds or None, got {read_timeout_s}")
        self.app = app
        self.max_body_bytes = max_body_bytes
        self.path_limits = dict(path_limits or {})
        self.read_timeout_s = read_timeout_s
        self.clock = clock

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        state = scope.setdefault("state", {})
        state[QUEUED_SINCE] = self.clock()
        limit, setting = self.path_limits.get(
            scope.get("path", ""), (self.max_body_bytes, "JARVIS_MAX_BODY_BYTES")
        )
        declared = _declared_length(scope)
        if declared is not None and declared > limit:
            await _refuse(
                send,
                413,
                PAYLOAD_TOO_LARGE,
                f"the request body declares {declared} bytes; " + _limit(limit, setting),
            )
            return

        received = 0
        refused: BodyRefused | None = None
        body_done = False

        async def guarded_receive() -> Message:
            nonlocal received, refused, body_done
            if body_done or self.read_timeout_s is None:
                message = await receive()  # after the body: waiting for a disconnect is no slow body
            else:
                try:
                    with anyio.fail_after(self.read_timeout_s):
                        message = await receive()
                except TimeoutError:
                    refused = _BodyTimedOut()
                    raise refused from None
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    refused = _BodyTooLarge()
                    raise refused
                if not message.get("more_body", False):
                    body_done = True
                    state[QUEUED_SINCE] = self.clock()
            return message

        async def guarded_send(message: Message) -> None:
            # Once the body was refused, whatever the app makes of the truncated read is not sent.
            if refused is None:
                await send(message)

        with contextlib.suppress(BodyRefused):
            await self.app(scope, guarded_receive, guarded_send)
        if isinstance(refused, _BodyTooLarge):
            detail = f"the request body streamed more than {limit} bytes; " + _limit(limit, setting)
            await _refuse(send, 413, PAYLOAD_TOO_LARGE, detail)
        elif isinstance(refused, _BodyTimedOut):
            detail = (
                f"no part of the request body arrived for {self.read_timeout_s:g} s after {received} bytes; "
                "the request was dropped (setting JARVIS_BODY_READ_TIMEOUT_S)"
            )
            await _refuse(send, 408, REQUEST_TIMEOUT, detail)


def _limit(limit: int, setting: str) -> str:
    return f"the limit is {limit} bytes (setting {setting})"


async def _refuse(send: Send, status: int, code: str, detail: str) -> None:
    """The error body with ``Connection: close``: the rest of the body is never read, so the connection
    cannot carry another request."""
    body = json.dumps({"error": code, "detail": detail}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


def _declared_length(scope: Scope) -> int | None:
    """The integer Content-Length header, or None when absent or not a number (then bytes are counted)."""
    for name, value in scope["headers"]:
        if name == b"content-length":
            try:
                return int(value)
            except ValueError:
                return None
    return None
