"""Refuse request bodies over the limit before anything parses them (DESIGN.md §4: 413 over the limit).

A pure ASGI middleware so it sees the raw byte stream: a declared ``Content-Length`` over the limit is
refused without reading a byte, and a body without one (chunked) is counted as it streams and cut off
the moment it passes the limit, so a client cannot make the process buffer an unbounded body. A route
may have its own limit (``path_limits``): TEACh's ``/start_new_edh_instance`` carries a whole EDH history
of JPEG frames, far more than any native request.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Mapping

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.errors import PAYLOAD_TOO_LARGE


class _BodyTooLarge(Exception):
    """Raised from ``receive`` to stop the application reading further."""


class BodySizeLimit:
    """ASGI middleware answering 413 ``payload_too_large`` to bodies over ``max_body_bytes`` (or over the
    limit ``path_limits`` gives the request's exact path, with the setting that sets it)."""

    def __init__(
        self,
        app: ASGIApp,
        max_body_bytes: int,
        path_limits: Mapping[str, tuple[int, str]] | None = None,
    ) -> None:
        limits = {"": (max_body_bytes, "JARVIS_MAX_BODY_BYTES"), **(path_limits or {})}
        for path, (limit, _) in limits.items():
            if limit < 1:
                raise ValueError(f"the body limit of {path or 'every path'!r} must be positive, got {limit}")
        self.app = app
        self.max_body_bytes = max_body_bytes
        self.path_limits = dict(path_limits or {})

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit, setting = self.path_limits.get(
            scope.get("path", ""), (self.max_body_bytes, "JARVIS_MAX_BODY_BYTES")
        )
        declared = _declared_length(scope)
        if declared is not None and declared > limit:
            await self._refuse(send, f"the request body declares {declared} bytes", limit, setting)
            return

        received = 0
        exceeded = False

        async def counting_receive() -> Message:
            nonlocal received, exceeded
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    exceeded = True
                    raise _BodyTooLarge
            return message

        async def guarded_send(message: Message) -> None:
            # Once the body overflowed, whatever the app makes of the truncated read is not sent.
            if not exceeded:
                await send(message)

        with contextlib.suppress(_BodyTooLarge):
            await self.app(scope, counting_receive, guarded_send)
        if exceeded:
            await self._refuse(send, f"the request body streamed more than {limit} bytes", limit, setting)

    async def _refuse(self, send: Send, what: str, limit: int, setting: str) -> None:
        detail = f"{what}; the limit is {limit} bytes (setting {setting})"
        body = json.dumps({"error": PAYLOAD_TOO_LARGE, "detail": detail}).encode()
        await send(
            {
                "type": "http.response.start",
                "status": 413,
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
