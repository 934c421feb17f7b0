"""Refuse request bodies over the limit before anything parses them (DESIGN.md §4: 413 over the limit).

A pure ASGI middleware so it sees the raw byte stream: a declared ``Content-Length`` over the limit is
refused without reading a byte, and a body without one (chunked) is counted as it streams and cut off
the moment it passes the limit, so a client cannot make the process buffer an unbounded body.
"""

from __future__ import annotations

import contextlib
import json

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.errors import PAYLOAD_TOO_LARGE


class _BodyTooLarge(Exception):
    """Raised from ``receive`` to stop the application reading further."""


class BodySizeLimit:
    """ASGI middleware answering 413 ``payload_too_large`` to bodies over ``max_body_bytes``."""

    def __init__(self, app: ASGIApp, max_body_bytes: int) -> None:
        if max_body_bytes < 1:
            raise ValueError(f"max_body_bytes must be positive, got {max_body_bytes}")
        self.app = app
        self.max_body_bytes = max_body_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = _declared_length(scope)
        if declared is not None and declared > self.max_body_bytes:
            await self._refuse(send, f"the request body declares {declared} bytes")
            return

        received = 0
        exceeded = False

        async def counting_receive() -> Message:
            nonlocal received, exceeded
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_body_bytes:
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
            await self._refuse(send, f"the request body streamed more than {self.max_body_bytes} bytes")

    async def _refuse(self, send: Send, what: str) -> None:
        detail = f"{what}; the limit is {self.max_body_bytes} bytes (setting JARVIS_MAX_BODY_BYTES)"
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
