"""The live pages: a list of the caller's sessions, one page per session, and the event stream that feeds it.

The pages and their script are static files shipped in the package (``app/static``; no CDN, no build step;
each page's content goes into the frame all pages share, ``page.html``), so they answer without a key and
hold no session data. The script reads an API key, when the service needs one, from the page address's
fragment (``/v1/view#key=KEY``: a fragment never reaches a server or its logs) and sends it as
``Authorization: Bearer`` with every request, the event stream included (it reads the stream with ``fetch``,
which can send headers where ``EventSource`` cannot).

``GET /v1/sessions/{id}/events`` is a server-sent event stream of the session's views (``app.live_view``):
one ``view`` event per completed change, its ``id`` the view's revision (``<steps>.<turns>``), so a client
that reconnects with ``Last-Event-ID`` gets nothing it already has; a comment line after
``live_heartbeat_s`` of quiet; a ``gone`` event, and the end of the stream, when the session is deleted or
expires. The stream is an async generator polling the store's revision every ``live_poll_s``: no worker
thread is held per watching client.
"""

from __future__ import annotations

import asyncio
import contextlib
import string
import time
from collections.abc import AsyncIterator
from functools import cache
from importlib import resources
from typing import Annotated

import anyio.to_thread
import orjson
import redis
from fastapi import APIRouter, Header, Response
from fastapi.responses import HTMLResponse, StreamingResponse

from app.api.deps import CallerDep, SettingsDep, StoreDep, ViewDep
from app.live_view import SessionView
from app.store import SessionNotFound, SessionStore

# Not in the OpenAPI description: pages are for people, and an endless event stream is beyond what it can
# describe (a schema fuzzer would wait on it for ever). This docstring and app/README.md describe them.
router = APIRouter(tags=["live view"], include_in_schema=False)
EVENT_STREAM = "text/event-stream"
RECONNECT_MS = 2000
"""What the stream tells a client to wait before reconnecting (SSE ``retry:``)."""
WATCH_POLLS, WATCH_SLACK_S = 3, 2.0
"""A stream marks its session watched (so steps store their frames) until this many polls and seconds from
now; a closed page's mark lapses then."""


@cache
def _static(name: str) -> bytes:
    """A file of ``app/static``, read once per process."""
    return resources.files("app").joinpath("static", name).read_bytes()


@cache
def _page(name: str) -> bytes:
    """Live page ``name``: ``static/<name>.html`` in the frame every page shares (``static/page.html``: the
    head with its title and style sheet, the script)."""
    frame = string.Template(_static("page.html").decode())
    content = _static(f"{name}.html").decode().removesuffix("\n")
    return frame.substitute(page=name, content=content).encode()


@router.get("/v1/view", response_class=HTMLResponse)
async def sessions_page() -> HTMLResponse:
    """The caller's sessions, as links to their pages (the script fetches ``GET /v1/sessions``)."""
    return HTMLResponse(_page("sessions"))


@router.get("/v1/sessions/{session_id}/view", response_class=HTMLResponse)
async def session_page(session_id: str) -> HTMLResponse:
    """One session, live: the same static page for every id (the script follows the id's event stream)."""
    return HTMLResponse(_page("session"))


@router.get("/v1/view/live.js")
async def page_script() -> Response:
    return Response(_static("live.js"), media_type="text/javascript")


@router.get("/v1/view/live.css")
async def page_style() -> Response:
    return Response(_static("live.css"), media_type="text/css")


@router.get(
    "/v1/sessions/{session_id}/events",
    response_class=StreamingResponse,
)
async def session_events(
    session_id: str,
    view: ViewDep,
    store: StoreDep,
    caller: CallerDep,
    settings: SettingsDep,
    last_event_id: Annotated[str | None, Header(alias="Last-Event-ID")] = None,
) -> StreamingResponse:
    stream = _events(
        view, store, caller.owner, last_event_id, settings.live_poll_s, settings.live_heartbeat_s
    )
    return StreamingResponse(
        stream,
        media_type=EVENT_STREAM,
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},  # nginx: do not buffer the stream
    )


async def _events(
    view: SessionView,
    store: SessionStore,
    owner: str | None,
    last_event_id: str | None,
    poll_s: float,
    heartbeat_s: float,
) -> AsyncIterator[bytes]:
    """The stream: the latest view when the client has not seen it, then each newer one, until the session
    is gone. Starlette ends the generator when the client disconnects."""
    yield f"retry: {RECONNECT_MS}\n\n".encode()
    sent = last_event_id
    quiet_since = time.monotonic()
    watch_s = WATCH_POLLS * poll_s + WATCH_SLACK_S
    with contextlib.suppress(SessionNotFound, redis.RedisError):  # the loop below reports either
        await store.view_revision(view.session_id, owner, watch_s=watch_s)  # frames from the next step
    while True:
        if view.revision != sent:
            yield await _view_event(view)
            sent = view.revision
            quiet_since = time.monotonic()
        elif time.monotonic() - quiet_since >= heartbeat_s:
            yield b": keep-alive\n\n"
            quiet_since = time.monotonic()
        await asyncio.sleep(poll_s)
        try:
            if await store.view_revision(view.session_id, owner, watch_s=watch_s) != view.revision:
                view = await store.view(view.session_id, owner, touch=False)
        except SessionNotFound:
            detail = "the session was deleted or expired"
            yield _event("gone", {"session_id": view.session_id, "detail": detail})
            return
        except redis.RedisError as error:
            # The client reconnects (``retry``) and resumes from its last event once Redis answers again.
            yield _event(
                "unavailable", {"detail": f"the session store did not answer ({type(error).__name__})"}
            )
            return


async def _view_event(view: SessionView) -> bytes:
    # Drawing the map takes ~6 ms once per view and worker: not on the event loop.
    data = view.event() if view.map_drawn else await anyio.to_thread.run_sync(view.event)
    return _event("view", data, event_id=view.revision)


def _event(name: str, data: object, event_id: str | None = None) -> bytes:
    head = f"id: {event_id}\n" if event_id is not None else ""
    return f"{head}event: {name}\ndata: ".encode() + orjson.dumps(data) + b"\n\n"
