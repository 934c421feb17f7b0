"""Refuse work that waited too long to start (503 ``overloaded`` with ``Retry-After``).

The session and step work runs in a pool of worker threads; under overload requests queue for a thread,
and a request served after its client gave up is work for nobody that delays every request behind it.
``refuse_stale_request`` is synchronous, so it runs once the request got its worker thread, right before
its work: a request that waited longer than ``request_queue_deadline_s`` since its body was read
(``app.body_limit.QUEUED_SINCE``) answers 503 there, before anything changes. The session and TEACh routes
take it as a dependency; the step route calls it first in the one worker-thread call it makes. Health,
readiness and metrics are exempt: a probe must see the process alive however busy it is.
"""

from __future__ import annotations

import math
import time

from fastapi import Request

from app.body_limit import QUEUED_SINCE
from app.errors import OVERLOADED, ApiError
from app.settings import Settings

EXEMPT_PATHS = frozenset({"/healthz", "/readyz", "/metrics", "/test", "/ping"})
"""Liveness, readiness, metrics and TEACh's connection checks: cheap, and wanted most under load."""


def refuse_stale_request(request: Request) -> None:
    """503 ``overloaded`` when the request queued longer than ``request_queue_deadline_s``; Retry-After is
    the time it queued (the backlog it found took that long to reach it)."""
    if request.url.path in EXEMPT_PATHS:
        return
    since = request.scope.get("state", {}).get(QUEUED_SINCE)
    settings: Settings = request.app.state.settings
    if since is None:
        return
    waited = time.monotonic() - since
    if waited > settings.request_queue_deadline_s:
        raise ApiError(
            503,
            OVERLOADED,
            f"the service is overloaded: this request waited {waited:.1f} s for a worker, more than "
            f"{settings.request_queue_deadline_s:g} s (setting JARVIS_REQUEST_QUEUE_DEADLINE_S); nothing "
            "was done, retry later",
            headers={"Retry-After": str(max(1, math.ceil(waited)))},
        )
