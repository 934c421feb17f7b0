"""Keep-alive connections that end now and then, so work spreads over worker processes again.

Several workers share one listening socket and the kernel gives each new connection to whichever worker
accepts it, but a client with a connection pool keeps its connections for as long as the service does. A
connection opened while one worker was busy, or while a killed worker's replacement was still starting,
stays with the worker that took it: in ``bench/load_fault.py`` 32 sessions on 2 workers ran with 1.5 of 2
cores busy, and after a worker was killed every connection sat on the survivor (half the throughput for
the rest of the run). So every ``every``-th answer on a connection says ``Connection: close``; the client
opens a new one for its next request, and the worker least busy accepting it takes it. HTTP clients
(``requests``, httpx, curl) reconnect on their own; the cost is one loopback handshake per ``every``
requests.
"""

from __future__ import annotations

from collections import OrderedDict

from starlette.types import ASGIApp, Message, Receive, Scope, Send

TRACKED_CONNECTIONS = 8192
"""Connections counted at once; the least recently used is forgotten (it was most likely closed)."""


class ConnectionRecycling:
    """ASGI middleware closing each keep-alive connection after ``every`` answered requests."""

    def __init__(self, app: ASGIApp, every: int) -> None:
        if every < 1:
            raise ValueError(f"every must be at least 1 request, got {every}")
        self.app = app
        self.every = every
        self._counts: OrderedDict[tuple[str, int], int] = OrderedDict()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        client = scope.get("client")
        if scope["type"] != "http" or client is None:
            await self.app(scope, receive, send)
            return
        connection = (str(client[0]), int(client[1]))  # one keep-alive connection's peer address
        count = self._counts.pop(connection, 0) + 1
        last = count >= self.every
        if not last:
            self._counts[connection] = count  # most recently used last
            while len(self._counts) > TRACKED_CONNECTIONS:
                self._counts.popitem(last=False)

        async def closing_send(message: Message) -> None:
            if last and message["type"] == "http.response.start":
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() != b"connection"]
                message = {**message, "headers": [*headers, (b"connection", b"close")]}
            await send(message)

        await self.app(scope, receive, closing_send)
